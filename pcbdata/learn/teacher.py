"""The cloning teacher for runs without `finish` (`pcbdata train --no-finish`).

The scripted agents route by `finish`; with the action masked out (environment option
`finish=False`) they would stall. `WithoutFinish` wraps one: it shows the agent masks in which
`finish` is allowed wherever a target exists, and turns each `finish` it answers into the
`make_line` in the same mode to the pad `finish` would have aimed at, as near as the
observation tells: a pad candidate on the head's layer at the far end of an open ratsnest edge
of the net from the head (or from the route's start pad), else the nearest pad candidate on
that layer at an end of any open edge of the net. So every action the teacher sends is one the
environment offers, and the demonstrations hold no `finish`.
"""
from __future__ import annotations

import numpy as np

from pcbdata.env.types import FINISH, MAKE_LINE, PAD, ROUTING, START_ROUTE


def _open_edges(obs, net: int) -> np.ndarray:
    geo = obs["routing_geometry"]
    edges = geo["ratsnest"][: int(geo["ratsnest_count"])]
    return edges[edges[:, 1] == net]


class WithoutFinish:
    """A scripted agent whose `finish` becomes a `make_line` to a pad candidate."""

    def __init__(self, agent):
        self.agent = agent
        self._start: tuple[float, float] | None = None

    @property
    def done(self) -> bool:
        return bool(getattr(self.agent, "done", False))

    def act(self, obs, info) -> dict:
        head = obs["router_head"]
        target = self.target(obs, info["action_mask"]) if int(head["phase"]) == ROUTING else None
        masks = dict(info["action_mask"])
        masks["type"] = masks["type"].copy()
        masks["type"][FINISH] = target is not None
        chosen = self.agent.act(obs, {**info, "action_mask": masks})
        if chosen["type"] == START_ROUTE:
            c = head["candidates"][int(chosen["candidate"])]
            self._start = (float(c[1]), float(c[2]))
        if chosen["type"] == FINISH:
            assert target is not None  # offered only with a target
            return {"type": MAKE_LINE, "net": 0, "candidate": target, "mode": chosen["mode"]}
        return chosen

    def target(self, obs, masks: dict) -> int | None:
        """The candidate slot `finish` is replaced by (None: no pad to aim at)."""
        head = obs["router_head"]
        hx, hy, layer = float(head["position"][0]), float(head["position"][1]), int(head["layer"])
        edges = _open_edges(obs, int(head["net"]))
        pads: dict[tuple, int] = {}  # (x, y) -> candidate slot: the net's pads on the layer
        for i, c in enumerate(head["candidates"]):
            if masks["candidate"][i] and int(c[0]) == PAD and int(c[3]) == layer:
                pads.setdefault((float(c[1]), float(c[2])), i)
        for anchor in ((hx, hy), self._start):
            far = [(e[4], e[5]) if (e[2], e[3]) == anchor else (e[2], e[3])
                   for e in edges if anchor in ((e[2], e[3]), (e[4], e[5]))]
            slot = self._nearest(hx, hy, [p for p in far if p in pads], pads)
            if slot is not None:
                return slot
        ends = {(float(e[k]), float(e[k + 1])) for e in edges for k in (2, 4)}
        return self._nearest(hx, hy, [p for p in ends if p in pads and p != (hx, hy)], pads)

    @staticmethod
    def _nearest(hx: float, hy: float, points: list, pads: dict) -> int | None:
        if not points:
            return None
        best = min(points, key=lambda p: ((p[0] - hx) ** 2 + (p[1] - hy) ** 2, p))
        return pads[best]
