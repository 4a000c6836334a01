"""pcbdata.spec."""
