"""Test support that ships with pcbdata, for its own tests and benchmarks and for users who
test code on pcbdata's boards (like `numpy.testing`): small sets (`sets`), DRC exercises
(`drc`), and D2 boards routed router-only with an exact independent check (`d2_routes`).
The top layer: it may import anything of pcbdata, and nothing imports it."""
