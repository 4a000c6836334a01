"""pcbdata.synthetic."""
