"""pcbdata.model."""
