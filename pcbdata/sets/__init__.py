"""What a board set is: the registry of configs and their resolution against a built set
(`configs`), the versioned presets and levels of the generator families (`presets`), the D3
curation recipe (`recipe`), the releases pinned in the package (`releases`), a set's identity
in reports (`identity`) and the verification of a built set against its manifest and its
release (`verify`, which also reads the published parts through `pcbdata.publish.audit`).
"""
