"""The versioned D3 curation recipe (installed as `pcbdata._recipe_files`)."""
