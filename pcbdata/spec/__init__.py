"""What a board set is: the registry of configs (`configs`), the versioned D1/D2 presets and
levels (`presets`) and the D3 curation recipe (`recipe`)."""
