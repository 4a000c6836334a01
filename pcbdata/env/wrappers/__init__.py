"""pcbdata.env.wrappers."""
