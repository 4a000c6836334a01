"""pcbdata.core."""
