"""The scripted rule-based baseline, `act(obs, info) -> action`: it reads only the observation
and `info["action_mask"]`.

`ScriptedAgent` (the environment's own baseline): nets in order of their pads' bounding box
(small first; `seed` > 0 perturbs the order for @k rollouts); per net it starts at an end of
the shortest open ratsnest edge, on a layer both pads share if any, and calls `finish` in
`walkaround` mode until the net is joined; when the head's layer has no reachable pad it drops
a via at the head (never on a drilled pad: it restarts on the pad's other layer instead) and
goes on from the other layer; where that via does not fit on a surface pad (a fine-pitch
row), it drops one a ring step beside the pad, facing the net's nearest open end first, else
walks a ring step toward that end (at most `ESCAPE_WALK`) and tries there; it releases
the net when done or out of ideas (the environment's `net_end` then takes up the vias and
stubs of routes that went nowhere, with its default `cleanup`). With
`shove=True` (`ShovingScriptedAgent`, `--agent scripted-shove`) a `finish` that walkaround cannot
route is tried once more in `push_n_shove` mode before the via.
"""
from __future__ import annotations

import numpy as np

from pcbdata.env.candidates import RING_SLOTS
from pcbdata.env.types import (
    FINISH,
    IDLE,
    MAKE_LINE,
    MAKE_VIA,
    NET,
    NET_END,
    NET_SELECT,
    NO_NET,
    PAD,
    PUSH_N_SHOVE,
    START_ROUTE,
    WALKAROUND,
)

#: Ring steps an escape may walk from a surface pad before it gives up on a via.
ESCAPE_WALK = 2


def action(kind: int, net: int = 0, candidate: int = 0, mode: int = WALKAROUND) -> dict:
    return {"type": kind, "net": net, "candidate": candidate, "mode": mode}


def open_edges(obs) -> np.ndarray:
    geo = obs["routing_geometry"]
    return geo["ratsnest"][: int(geo["ratsnest_count"])]


def _pads_at(obs, key: tuple) -> np.ndarray:
    """The rows of `board_static.pads` centred at the head key's (x, y)."""
    pads = obs["board_static"]["pads"]
    return pads[(pads[:, 0] == 1) & (pads[:, 2] == key[0]) & (pads[:, 3] == key[1])]


def _net_order(obs, seed: int) -> list[int]:
    """Net indices by the half-perimeter of their pads' bounding box, small first."""
    static = obs["board_static"]
    pads = static["pads"][static["pads"][:, 0] == 1]
    keys = []
    for net in sorted(set(int(n) for n in pads[:, 1] if n >= 0)):
        xy = pads[pads[:, 1] == net][:, 2:4]
        keys.append((float(np.ptp(xy[:, 0]) + np.ptp(xy[:, 1])), net))
    order = [net for _, net in sorted(keys)]
    rng = np.random.default_rng(seed)
    for i in range(len(order) - 1):  # seeded adjacent swaps: a nearby order per rollout
        if seed and rng.random() < 0.5:
            order[i], order[i + 1] = order[i + 1], order[i]
    return order


class ScriptedAgent:
    """The rule-based baseline (see the module doc). `done` turns True when it has nothing
    left to try (a runner may then stop the episode early)."""

    def __init__(self, seed: int = 0, tries_per_net: int = 6, mode: int = WALKAROUND,
                 shove: bool = False):
        self.seed = seed
        self.tries_per_net = tries_per_net
        self.mode = mode  # WALKAROUND; MARK_OBSTACLES lays lines through obstacles (demos, tests)
        self.shove = shove  # when `finish` finds no path, try it once more in push_n_shove mode
        self._board = None

    def _new_episode(self, obs) -> None:
        self._order = _net_order(obs, self.seed)
        self._tries: dict[int, int] = {}
        self._started: set[tuple] = set()
        self._gave_up: set[int] = set()
        self._finish_failed: set[tuple] = set()
        self._shove_failed: set[tuple] = set()
        self._vias: set[tuple] = set()
        self._vias_beside: set[tuple] = set()  # (head, ring slot or "walk") tried
        self._walked: dict[tuple, tuple] = {}  # heads an escape walk reached: (depth, goal)
        self._walking: tuple | None = None
        self._last, self._last_mode = IDLE, self.mode
        self.done = False

    def act(self, obs, info) -> dict:
        if int(obs["step"]) == 0 or self._board != info.get("board_id"):
            self._board = info.get("board_id")
            self._new_episode(obs)
        head = obs["router_head"]
        if self._last == FINISH and info.get("router") and not info["router"]["ok"]:
            failed = self._shove_failed if self._last_mode == PUSH_N_SHOVE else self._finish_failed
            failed.add(self._head_key(obs))
        if self._walking and info.get("router") and info["router"]["ok"]:
            self._walked[self._head_key(obs)] = self._walking
        self._walking = None
        phase = int(head["phase"])
        if phase == NO_NET:
            chosen = self._select(obs, info)
        elif phase == NET:
            chosen = self._start(obs, info)
        else:
            chosen = self._route(obs, info)
        self._last, self._last_mode = chosen["type"], chosen["mode"]
        return chosen

    @staticmethod
    def _head_key(obs) -> tuple:
        head = obs["router_head"]
        return (float(head["position"][0]), float(head["position"][1]), int(head["layer"]))

    def _select(self, obs, info) -> dict:
        open_nets = {int(e[1]) for e in open_edges(obs)}
        for net in self._order:
            if net in open_nets and net not in self._gave_up and info["action_mask"]["net"][net]:
                return action(NET_SELECT, net=net)
        self.done = True
        return action(IDLE)

    def _pad_layers(self, obs, x: float, y: float) -> list[int]:
        static = obs["board_static"]
        rows = np.flatnonzero((static["pads"][:, 0] == 1) & (static["pads"][:, 2] == x)
                              & (static["pads"][:, 3] == y))
        if not rows.size:
            return []
        return [int(layer) for layer in np.flatnonzero(static["pad_layers"][rows[0]])]

    def _start_options(self, obs, net: int) -> list[tuple]:
        """(x, y, layer) starts: ends of the net's open edges, shortest edge first, layers the
        two pads share first."""
        edges = [e for e in open_edges(obs) if int(e[1]) == net]
        edges.sort(key=lambda e: ((e[2] - e[4]) ** 2 + (e[3] - e[5]) ** 2, tuple(e)))
        options = []
        for e in edges:
            ends = [(float(e[2]), float(e[3])), (float(e[4]), float(e[5]))]
            shared = set(self._pad_layers(obs, *ends[0])) & set(self._pad_layers(obs, *ends[1]))
            for x, y in ends:
                layers = self._pad_layers(obs, x, y)
                ordered = sorted(layers, key=lambda layer: layer not in shared)
                options += [(x, y, layer) for layer in ordered]
        return options

    def _start(self, obs, info) -> dict:
        net = int(obs["router_head"]["net"])
        self._tries[net] = self._tries.get(net, 0) + 1
        cands = obs["router_head"]["candidates"]
        mask = info["action_mask"]["candidate"]
        if self._tries[net] <= self.tries_per_net:
            for x, y, layer in self._start_options(obs, net):
                if (net, x, y, layer) in self._started:
                    continue
                for i, c in enumerate(cands):
                    if mask[i] and c[0] == PAD and (c[1], c[2], int(c[3])) == (x, y, layer):
                        self._started.add((net, x, y, layer))
                        return action(START_ROUTE, candidate=i)
        self._gave_up.add(net)
        return action(NET_END)

    def _route(self, obs, info) -> dict:
        net = int(obs["router_head"]["net"])
        m = info["action_mask"]
        if not any(int(e[1]) == net for e in open_edges(obs)):
            return action(NET_END)
        key = self._head_key(obs)
        if key in self._walked:  # a ring step from where `finish` failed: a via, or walk on
            return self._via_action(obs, info, key) or action(NET_END)
        if m["type"][FINISH] and m["mode"][self.mode] and key not in self._finish_failed:
            return action(FINISH, mode=self.mode)
        if self.shove and m["type"][FINISH] and m["mode"][PUSH_N_SHOVE] \
                and key not in self._shove_failed:
            return action(FINISH, mode=PUSH_N_SHOVE)
        return self._via_action(obs, info, key) or action(NET_END)  # restart, or give up

    def _via_action(self, obs, info, key: tuple) -> dict | None:
        via = self._via_here(obs, info, key)
        if via is not None:
            self._vias.add(key[:2])
            return action(MAKE_VIA, candidate=via, mode=self.mode)
        return self._escape(obs, info, key)

    def _escape(self, obs, info, key: tuple) -> dict | None:
        """Off a surface pad where no via fits (a fine-pitch row): a via one ring step beside
        the head, else a ring step's walk (at most ESCAPE_WALK) and the same from there."""
        if self._on_surface_pad(obs, key):
            depth, toward = 0, self._nearest_open_end(obs, key)
        else:
            depth, toward = self._walked.get(key, (None, None))
        if depth is None or toward is None or not info["action_mask"]["type"][MAKE_VIA]:
            return None  # elsewhere the head can move first; a drilled pad spans the layers
        slots = self._facing_slots(obs, info, key, toward, "candidate_via", wide=depth == 0)
        slots = [i for i in slots if (key, i) not in self._vias_beside]
        if slots:
            self._vias_beside.add((key, slots[0]))
            return action(MAKE_VIA, candidate=slots[0], mode=self.mode)
        walks = self._facing_slots(obs, info, key, toward, "candidate", wide=False)
        if depth < ESCAPE_WALK and walks and (key, "walk") not in self._vias_beside:
            self._vias_beside.add((key, "walk"))
            self._walking = (depth + 1, toward)
            return action(MAKE_LINE, candidate=walks[0], mode=self.mode)
        return None

    def _via_here(self, obs, info, key: tuple) -> int | None:
        """The candidate at the head for a via, unless the head sits on a drilled pad or a via
        was already dropped here."""
        drilled = (_pads_at(obs, key)[:, 7] > 0).any()
        if drilled or key[:2] in self._vias or not info["action_mask"]["type"][MAKE_VIA]:
            return None
        for i, c in enumerate(obs["router_head"]["candidates"]):
            if info["action_mask"]["candidate_via"][i] and (c[1], c[2], int(c[3])) == key:
                return i
        return None

    @staticmethod
    def _facing_slots(obs, info, key: tuple, toward, mask: str, wide: bool) -> list[int]:
        """Ring slots allowed by `mask`, facing `toward` first; all eight when `wide`, else
        those within 90 degrees of it."""
        cands = obs["router_head"]["candidates"]
        heading = np.arctan2(toward[1] - key[1], toward[0] - key[0])

        def turn(i: int) -> float:
            angle = np.arctan2(cands[i][2] - key[1], cands[i][1] - key[0]) - heading
            return round(float(abs((angle + np.pi) % (2 * np.pi) - np.pi)), 6)
        slots = [i for i in range(RING_SLOTS) if info["action_mask"][mask][i]
                 and (wide or turn(i) <= np.pi / 2 + 1e-6)]
        return sorted(slots, key=lambda i: (turn(i), i))

    @staticmethod
    def _on_surface_pad(obs, key: tuple) -> bool:
        here = _pads_at(obs, key)
        return bool(len(here) and not (here[:, 7] > 0).any())

    @staticmethod
    def _nearest_open_end(obs, key: tuple) -> tuple[float, float] | None:
        net = int(obs["router_head"]["net"])
        ends = [(float(e[k]), float(e[k + 1])) for e in open_edges(obs) if int(e[1]) == net
                for k in (2, 4)]
        ends = [p for p in ends if p != key[:2]]
        return min(ends, key=lambda p: ((p[0] - key[0]) ** 2 + (p[1] - key[1]) ** 2, p),
                   default=None)


class ShovingScriptedAgent(ScriptedAgent):
    """The scripted baseline with the push_n_shove fallback (`--agent scripted-shove`)."""

    def __init__(self, seed: int = 0, tries_per_net: int = 6):
        super().__init__(seed, tries_per_net, WALKAROUND, shove=True)
