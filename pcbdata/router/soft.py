"""Copper a search may cross at a price (negotiated routing, PathFinder style): the planned
copper of other connections, each connection with its price (`SoftCopper`). The layered
search (`pcbdata.router.layered`) adds to a link's length the prices of the connections whose
copper it comes too close to (exact distances, each connection once per segment), and to a
via's cost those its via comes too close to; the planner then rips those connections up.
The search's first window that holds a way gives the answer: a cheaper way farther out is not
looked for."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from pcbdata.router import clearance_kernel
from pcbdata.router.clearance import _Layer, _lines, _Rules
from pcbdata.router.geometry import CopperItem


@dataclass(frozen=True)
class SoftCopper:
    """Items another search may cross, the owner (a connection) of each and its price (nm of
    track)."""

    items: tuple[CopperItem, ...]
    owners: tuple[int, ...]
    prices: dict[int, float]


class SoftLayer:
    """One layer's soft copper as rules for one width: the prices segments and dots pay."""

    def __init__(self, router, soft: SoftCopper, net: str, layer: str, width: int,
                 clearance: int):
        chosen = [i for i, item in enumerate(soft.items)
                  if layer in item.layers and item.net != net]
        records = []
        for i in chosen:
            item = soft.items[i]
            records.append((item.kind, item.net, item.clearance, router.prepared(item)))
        self.empty = not records
        if self.empty:
            return
        self.rules = _Rules(_Layer(records), -2, width / 2, clearance,
                            router.board.edge_clearance)
        self.owner = np.array([soft.owners[i] for i in chosen], dtype=np.int64)
        self.price = {o: float(p) for o, p in soft.prices.items()}

    def owners(self, segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(segment, owner) pairs, each once: the segment comes too close to the owner's
        copper."""
        if self.empty or not len(segments):
            return np.empty(0, np.int64), np.empty(0, np.int64)
        rules = self.rules
        if clearance_kernel.enabled():  # sure pairs compiled, the unsure ones measured below
            seg, item, status = rules.layer.grid.pairs(segments, rules.need, rules.max_need)
            unsure = status == 2
        else:
            seg, item = rules._near_pairs(segments)
            unsure = np.ones(len(seg), dtype=bool)
        if unsure.any():
            close = shapely.distance(_lines(segments[seg[unsure]]),
                                     rules.layer.cores[item[unsure]])
            keep = ~unsure
            keep[unsure] = close < rules.need[item[unsure]]
            seg, item = seg[keep], item[keep]
        # (segment, owner) pairs as one sortable code, segment first: a 1-D unique is cheap
        owner = self.owner[item]
        span = int(owner.max()) + 1 if len(owner) else 1
        codes = np.unique(seg.astype(np.int64) * span + owner)
        return codes // span, codes % span

    def prices(self, segments: np.ndarray) -> np.ndarray:
        """Per segment, the summed prices of the owners it comes too close to."""
        out = np.zeros(len(segments))
        seg, owner = self.owners(segments)
        if len(seg):
            np.add.at(out, seg, [self.price[int(o)] for o in owner])
        return out
