"""pcbdata.agents."""
