"""The language-model interface of the routing environment: the board as text (`text`), the
tool schema and strict reply parser (`tools`), and the wrapper and episode runner
(`wrapper`)."""
