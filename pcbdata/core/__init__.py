"""The leaves: modules every layer may import, the KiCad layer included. They import the
standard library, numpy, shapely (geometry) and Pillow (`drawing`) only, and each other.

errors, hashing, textio (canonical JSON/CSV), tree (the built tree's names and listing), fsutil
(atomic writes, folder locks), rng, sexpr_text (file text checks), ratsnest,
copper_geometry and copper_text (a submission's copper, without KiCad), drawing (pictures).
"""
