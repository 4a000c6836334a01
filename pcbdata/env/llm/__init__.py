"""pcbdata.env.llm.wrapper."""
