"""Versioned generator presets (installed as `pcbdata._preset_files`)."""
