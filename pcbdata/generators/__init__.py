"""Board generators: a generator is an object; (seed, split, index) in, instance out.

`base.Generator` is the protocol (with the guarantee every generator states: each instance
loads in KiCad 9.0.8 and has a DRC with no violations other than the unconnected items that
routing will resolve); `base.Family` is what a family tells the rest of pcbdata. One package
per family: `d1` (grid boards), `d2` (gridless two-layer boards, by level), `d2r` (realistic
boards, one level per D3 tier); `families` keeps the table of families (`register_family`).
`params` holds what every typed parameter set shares.
"""
