"""Board generators: a generator is an object; (seed, split, index) in, instance out.

`base.Generator` is the protocol (with the guarantee every generator states: each instance
loads in KiCad 9.0.8 and has a DRC with no violations other than the unconnected items that
routing will resolve); `D1Generator`, `D2Generator` and `D2RGenerator` (realistic boards)
implement it.
"""
from pcbdata.generators.base import Generator, Instance, SplitArrays
from pcbdata.generators.d1 import D1Generator, D1Params, GridInstance
from pcbdata.generators.d2 import D2Generator, D2Params
from pcbdata.generators.d2r import D2RGenerator, D2RParams

__all__ = ["Generator", "SplitArrays", "Instance", "GridInstance", "D1Generator", "D1Params",
           "D2Generator", "D2Params", "D2RGenerator", "D2RParams"]
