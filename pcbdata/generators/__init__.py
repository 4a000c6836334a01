"""Board generators: a generator is an object; (seed, split, index) in, instance out.

Each generator states its guarantee: every instance it returns loads in KiCad 9.0.8 and has a
DRC with no violations other than the unconnected items that routing will resolve.
"""
from pcbdata.generators.base import Instance
from pcbdata.generators.d1 import D1Generator, D1Params
from pcbdata.generators.d2 import D2Generator, D2Params

__all__ = ["Instance", "D1Generator", "D1Params", "D2Generator", "D2Params"]
