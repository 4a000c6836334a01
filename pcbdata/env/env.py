"""`RoutingEnv`: route one instance from its bare board (SPEC section 6).

KiCad's: the board model, the tracks and vias, connectivity, DRC with the instance's own rules,
saving (one KiCad worker process per environment, `pcbdata.env.session`). pcbdata's: the
walkaround path search, the mark-obstacles line, `finish`, candidates and masks.
"""
from __future__ import annotations

import time
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from pcbdata.env import candidates as cand
from pcbdata.env import masks, observation, operations
from pcbdata.env.actions import action_space, parse_action
from pcbdata.env.errors import BoardLoadError, EngineFailure, EnvValueError
from pcbdata.env.options import make_options, with_capacities
from pcbdata.env.reward import Telescope, board_state, canonical, counted, unconnected_from_clusters
from pcbdata.env.session import KicadSession
from pcbdata.env.sources import instance_files, make_source
from pcbdata.env.static import static_board
from pcbdata.env.types import (
    ACTION_TYPES,
    ENGINE,
    FINISH,
    MAKE_LINE,
    MAKE_VIA,
    MODES,
    NET,
    NET_END,
    NET_SELECT,
    PHASES,
    ROUTING,
    START_ROUTE,
    BoardView,
    Head,
)
from pcbdata.env.viewer import RENDER_MODES, RENDER_SIZE, state_records
from pcbdata.sets.configs import resolve_config

#: The default step limit's floor and its steps per connection left at reset (a connection
#: takes the scripted agent about five steps: net_select, start_route, finish, a via, net_end).
DEFAULT_MAX_STEPS = 200
STEPS_PER_CONNECTION = 8


def step_limit(connections: int) -> int:
    """The default step limit for a board with `connections` left to make."""
    return min(observation.MAX_STEP_COUNT,
               max(DEFAULT_MAX_STEPS, STEPS_PER_CONNECTION * int(connections)))


class RoutingEnv(gym.Env):
    @property
    def metadata(self) -> dict:  # type: ignore[override]
        # A property, so that gym.make hands render_mode="human" to __init__ (a clear error
        # naming the allowed modes) instead of wrapping the env in pygame's HumanRendering.
        return {"render_modes": list(RENDER_MODES), "render_fps": 4}

    # Set by __init__ / reset(); steps run only after reset() (Gymnasium's order).
    action_space: spaces.Dict
    observation_space: spaces.Dict
    static: Any
    _session: Any
    _head: Head | None
    _net: str | None
    _router: Any
    timings: dict[str, Any]

    def __init__(self, **options):
        checked = make_options(**options)
        # With a set, the config is what its manifest records (custom levels, placements).
        self.config = resolve_config(checked.config, None if checked.rows is not None
                                     else checked.root)
        self.options = o = with_capacities(checked, self.config.family)
        self.source = make_source(self.config, o.root, o.split, o.rows, o.count)
        self.action_space = action_space(o.max_nets, o.max_candidates)
        self.observation_space = observation.observation_space(o)
        if o.render_mode is not None and o.render_mode not in RENDER_MODES:
            raise EnvValueError(f"render_mode={o.render_mode!r} is not supported; allowed: "
                                f"{', '.join(RENDER_MODES)} (or None)")
        self.render_mode = o.render_mode
        self._session: KicadSession | None = None
        self.static = None
        self.timings = {"kicad_s": 0.0, "router_s": []}  # wall times: never in obs or info
        self._ended = True

    # ---- episode start -------------------------------------------------------------
    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        index = self._pick(options or {})
        if self._session is None:
            self._session = KicadSession(self.options.task_timeout, self.options.engine_env,
                                         self.options.fast_drc)
        folder = self.source.folder(index, self._session.work)
        self._files = instance_files(folder)
        try:
            opened = self._timed(self._session.open, *self._files)
        except EngineFailure as exc:
            raise BoardLoadError(f"{self.source.board_ids[index]}: {exc}") from None
        self.static = static_board(self.source.board_ids[index], opened["static"], self.config)
        self._check_capacity()
        self._begin(opened["snapshot"])
        info = self._info(rejected=None, router=None)
        info.update(net_names=[n.name for n in self.static.nets], layers=list(self.static.layers))
        return self._observation(), info

    @property
    def max_steps(self) -> int:
        """The step limit of the current episode: the `max_steps` option, or by default
        max(200, STEPS_PER_CONNECTION * the connections left to make at reset)."""
        return getattr(self, "_max_steps", self.options.max_steps or DEFAULT_MAX_STEPS)

    def _pick(self, options: dict) -> int:
        unknown = set(options) - {"board_id", "index"}
        if unknown:
            raise EnvValueError(f"unknown reset option(s) {sorted(unknown)}; use board_id or index")
        ids = self.source.board_ids
        if "board_id" in options:
            if options["board_id"] not in ids:
                raise EnvValueError(f"board_id {options['board_id']!r} is not in this "
                                    f"environment's {len(ids)} boards ({ids[0]} ... {ids[-1]})")
            return ids.index(options["board_id"])
        if "index" in options:
            index = int(options["index"])
            if not 0 <= index < len(ids):
                raise EnvValueError(f"index {index} out of range [0, {len(ids)})")
            return index
        return int(self.np_random.integers(len(ids)))

    def _check_capacity(self) -> None:
        s, o = self.static, self.options
        for name, have, cap in (("max_nets", len(s.nets), o.max_nets),
                                ("max_pads", len(s.pads), o.max_pads),
                                ("max_outline_points", sum(map(len, s.outline)),
                                 o.max_outline_points),
                                ("max_layers (32)", len(s.layers), observation.MAX_LAYERS)):
            if have > cap:
                raise BoardLoadError(f"{s.board_id}: {have} > {name}={cap}; pass {name}=... "
                                     f"to gym.make")

    def _begin(self, snap: dict) -> None:
        self._snap, self._violations = snap, canonical(snap["violations"])
        self._drc_fresh = True
        self._net, self._head, self._step_no = None, None, 0
        self._ended, self._terminated, self._truncated = False, False, False
        self._router, self._router_stale = None, False
        self._applied: list[dict] = []  # every edit KiCad accepted: a damaged worker is rebuilt
        self._state = self._measure()
        self._max_steps = self.options.max_steps or step_limit(self._state["unconnected"])
        self._telescope = Telescope(self._state["phi"], self.options.reward == "dense")
        self._static_obs = observation.static_part(self.static,
                                                   self.observation_space["board_static"])
        self._refresh_masks()

    def _timed(self, function, *args):
        began = time.perf_counter()
        try:
            return function(*args)
        finally:
            self.timings["kicad_s"] += time.perf_counter() - began

    # ---- measurement -----------------------------------------------------------------
    def _measure(self) -> dict:
        """The evaluator's board state (Phi, U, DRV...) of the current snapshot. Without a fresh
        DRC (drc="terminal"), unconnected items come from the pad clusters and other
        violations are not counted until the final DRC."""
        violations = self._violations if self._drc_fresh else \
            unconnected_from_clusters(self._snap["clusters"])
        measurement = {"violations": violations, "wl_mm": self._snap["wl_mm"],
                       "vias": self._snap["vias"], "net_count": self._snap["net_count"],
                       "clusters": self._snap["clusters"]}
        return board_state(measurement, self.options.weights, self.options.counting)

    def _counted(self) -> list[dict]:
        if not self._drc_fresh:
            return unconnected_from_clusters(self._snap["clusters"])
        return counted(self._violations, self.options.counting)

    # ---- masks -----------------------------------------------------------------------
    def _refresh_masks(self) -> None:
        s, o = self.static, self.options
        self._cands = cand.candidates(s, self._net, self._head, self._snap["copper"],
                                      round(o.ring_mm * 1e6), o.max_candidates)
        net = self._net_rules()
        margin = s.edge_clearance + (net.track_width // 2 if net else 0)
        line, via = masks.candidate_masks(s, self._cands, self._head, margin)
        nets = masks.net_mask(s, o.max_nets)
        modes, self._mode_reasons = masks.mode_mask()
        phase = masks.phase_of(self._net, self._head)
        can_finish = self.options.finish and phase == ROUTING and bool(self._finish_targets())
        self._masks = {"type": masks.type_mask(phase, bool(nets.any()), line, via, can_finish),
                       "net": nets, "candidate": line, "candidate_via": via, "mode": modes}

    def action_masks(self) -> dict:
        """Per-argument masks (1 = allowed): type, net, candidate (start_route / make_line),
        candidate_via (make_via), mode."""
        return {k: v.copy() for k, v in self._masks.items()}

    def _net_rules(self):
        return next((n for n in self.static.nets if n.name == self._net), None)

    def _current_head(self) -> Head:
        """The head (routing phase only: the masks allow no routing action without one)."""
        assert self._head is not None, "no head: the phase machine allows this only in routing"
        return self._head

    def _head_cluster(self) -> int | None:
        h, s, snap = self._current_head(), self.static, self._snap
        layer = s.layers[h.layer]
        for record in snap["copper"]:
            if record["net"] != self._net:
                continue
            if record["kind"] == "via" and (record["x"], record["y"]) == (h.x, h.y):
                return record["cluster"]
            if record["kind"] != "via" and record["layer"] == layer and \
                    (h.x, h.y) in (tuple(record["start"]), tuple(record["end"])):
                return record["cluster"]
        for i in s.pads_of(self._net):
            if (s.pads[i].x, s.pads[i].y) == (h.x, h.y) and h.layer in s.pads[i].layers:
                return snap["pad_cluster"][i]
        return None

    def _finish_targets(self) -> list[tuple[int, int]]:
        """Pad centres of the net on the head's layer not joined to the head's copper."""
        s, h = self.static, self._current_head()
        cluster = self._head_cluster()
        return sorted({(s.pads[i].x, s.pads[i].y) for i in s.pads_of(self._net)
                       if h.layer in s.pads[i].layers and self._snap["pad_cluster"][i] != cluster
                       and (s.pads[i].x, s.pads[i].y) != (h.x, h.y)})

    # ---- steps -----------------------------------------------------------------------
    def step(self, action):
        if self._ended or self.static is None:
            return self._after_end()
        self._step_no += 1
        parsed, rejected = parse_action(action, self.action_space)
        rejected = rejected or self._masked(parsed)
        router, changed = None, False
        if rejected is None:
            try:
                router, changed = self._do(parsed)
            except EngineFailure as exc:
                return self._step_failed(str(exc))
        return self._finish_step(rejected, router, changed)

    def _after_end(self):
        obs = self._observation() if self.static is not None else self.observation_space.sample()
        info = self._info(rejected="the episode has ended: call reset()", router=None) \
            if self.static is not None else {"rejected": "call reset() first"}
        return obs, 0.0, self._terminated, self._truncated, info

    def _masked(self, a) -> str | None:
        if a.point is not None:
            return self._point_masked(a)
        m, name = self._masks, ACTION_TYPES[a.type]
        if a.type == FINISH and not self.options.finish:
            return "finish is not offered (option finish=False)"
        if not m["type"][a.type]:
            return f"{name} is masked in phase {PHASES[masks.phase_of(self._net, self._head)]}"
        if a.type == NET_SELECT and not m["net"][a.net]:
            return f"net index {a.net}: " + ("unknown net" if a.net >= len(self.static.nets)
                                             else "a net with fewer than two pads")
        if a.type in (START_ROUTE, MAKE_LINE) and not m["candidate"][a.candidate]:
            return f"{name}: candidate {a.candidate} is masked"
        if a.type == MAKE_VIA and not m["candidate_via"][a.candidate]:
            return f"{name}: candidate {a.candidate} is masked for a via"
        if a.type in (MAKE_LINE, MAKE_VIA, FINISH) and not m["mode"][a.mode]:
            return f"{name}: mode {MODES[a.mode]}: " + self._mode_reasons.get(MODES[a.mode], "")
        return None

    def _point_masked(self, a) -> str | None:
        """Why a free-coordinate action cannot be taken (None: it can)."""
        name, phase = ACTION_TYPES[a.type], masks.phase_of(self._net, self._head)
        # A start_route by coordinates may also move the head while routing (the paper's
        # protocol re-anchors it after a via, or on the pad a line reached).
        wanted = {START_ROUTE: (NET, ROUTING), MAKE_LINE: (ROUTING,), MAKE_VIA: (ROUTING,)}
        if a.type not in wanted:
            return f"{name} takes no x, y (the free-coordinate form is for start_route, " \
                   f"make_line and make_via)"
        if phase not in wanted[a.type]:
            return f"{name} is masked in phase {PHASES[phase]}"
        if a.layer is not None and a.layer >= len(self.static.layers):
            return f"{name}: layer {a.layer} out of range [0, {len(self.static.layers)})"
        if a.type == START_ROUTE:
            if a.layer is None:
                return "start_route by coordinates needs a layer"
            return None if self._anchor(a.point, a.layer) else (
                f"start_route: ({a.point[0] / 1e6:.3f}, {a.point[1] / 1e6:.3f}) mm on "
                f"{self.static.layers[a.layer]} is no pad centre, track end or via of net "
                f"{self._net!r} (within {masks.POINT_TOLERANCE_NM / 1e6:g} mm)")
        if a.type == MAKE_VIA and self.static.grid_pitch is not None:
            return "make_via: D1 boards route on F.Cu only"
        if not masks.inside(self.static, a.point[0], a.point[1], 0):
            return f"{name}: ({a.point[0] / 1e6:.3f}, {a.point[1] / 1e6:.3f}) mm is outside " \
                   f"the board outline"
        if (a.type == MAKE_LINE and a.layer is not None
                and a.layer != self._current_head().layer):
            return "make_line stays on the head's layer (layer must be the head's or absent)"
        if not self._masks["mode"][a.mode]:
            return f"{name}: mode {MODES[a.mode]}: " + self._mode_reasons.get(MODES[a.mode], "")
        return None

    def _anchor(self, point, layer: int) -> Head | None:
        """The head a free-coordinate start_route takes: the pad centre, track end or via of
        the current net on `layer` nearest `point` within the tolerance (None: none)."""
        s, near = self.static, []
        for i in s.pads_of(self._net):
            if layer in s.pads[i].layers:
                near.append((s.pads[i].x, s.pads[i].y))
        name = s.layers[layer]
        for r in self._snap["copper"]:
            if r["net"] != self._net:
                continue
            if r["kind"] == "via":
                near.append((r["x"], r["y"]))
            elif r["layer"] == name:
                near += [tuple(r["start"]), tuple(r["end"])]
        best = min(near, key=lambda p: ((p[0] - point[0]) ** 2 + (p[1] - point[1]) ** 2, p),
                   default=None)
        if best is None or max(abs(best[0] - point[0]),
                               abs(best[1] - point[1])) > masks.POINT_TOLERANCE_NM:
            return None
        return Head(int(best[0]), int(best[1]), layer)

    def _do(self, a) -> tuple[dict | None, bool]:
        """Carries out an allowed action; returns (router report, copper changed)."""
        if a.type == NET_SELECT:
            self._net, self._head = self.static.nets[a.net].name, None
        elif a.type == NET_END:
            changed = self._prune([self._net])
            self._net, self._head = None, None
            return None, changed
        elif a.type == START_ROUTE:
            if a.point is not None:
                self._head = self._anchor(a.point, a.layer)
            else:
                c = self._cands[a.candidate]
                self._head = Head(c.x, c.y, c.layer)
        elif a.type in (MAKE_LINE, MAKE_VIA, FINISH):
            return self._route(a)
        return None, False

    def _route(self, a) -> tuple[dict, bool]:
        s, net, times = self.static, self._net_rules(), self.timings["router_s"]
        head = self._current_head()
        if a.point is not None:
            goal, target = a.point, a.layer
        else:
            c = self._cands[a.candidate]
            goal, target = (c.x, c.y), c.layer
        if a.type == MAKE_LINE:
            done = operations.make_line(s, self._get_router, net, head, goal, a.mode, times)
        elif a.type == MAKE_VIA:
            done = operations.make_via(s, self._get_router, net, head, goal, a.mode, times, target)
        else:
            done = operations.finish(s, self._get_router, net, head, self._finish_targets(),
                                  a.mode, self.options.finish_tries, times)
        report = {"ok": done.ok, "mode": MODES[a.mode], "reason": done.reason,
                  "stats": done.stats}
        if not done.ok:
            return report, False
        if done.edits:
            before = self._snap["clusters"]
            self._apply(done.edits)
            lost = operations.lost_connections(before, self._snap["clusters"], done.moved)
            if lost:  # KiCad is the judge: a moved net came apart, so the shove is undone
                self._apply(operations.undo(done.edits))
                report.update(ok=False, reason=f"push_n_shove: undone, KiCad's connectivity "
                                               f"shows net {lost[0]!r} lost a connection")
                return report, True
            # The pieces of moved tracks that the reroutes left behind.
            self._prune([n for n in done.moved if n != self._net])
        self._head = done.head
        return report, bool(done.edits)

    def board_view(self) -> BoardView:
        """The board as pcbdata's router sees it, read-only plain data (`types.BoardView`)."""
        from pcbdata.env.geometry_bridge import board_geometry

        if self.static is None:
            raise EnvValueError("call reset() first")
        return BoardView(self.static, board_geometry(self.static, self._snap["copper"]),
                         tuple(int(c) for c in self._snap["pad_cluster"]))

    def _get_router(self):
        """The episode's walkaround router, brought up to date with the board's copper (one
        router per episode: `update` reuses the shapes of items it has seen)."""
        if self._router is None or self._router_stale:
            from pcbdata.env.geometry_bridge import board_geometry
            from pcbdata.router.walkaround import WalkaroundRouter

            geometry = board_geometry(self.static, self._snap["copper"])
            if self._router is None:
                o = self.options
                self._router = WalkaroundRouter(geometry, budget_nodes=o.router_nodes,
                                                budget_checks=o.router_checks,
                                                budget_seconds=o.router_seconds)
            else:
                self._router.update(geometry)
            self._router_stale = False
        return self._router

    def _apply(self, edits: list[dict]) -> None:
        drc = self.options.drc == "step"
        self._took(self._timed(self._session.apply, edits, drc), edits, drc)

    def _prune(self, nets) -> bool:
        """With the `cleanup` option: KiCad deletes the nets' dangling tracks and vias
        (`routing_session.prune`), put back if a net came apart. True if copper changed."""
        nets = sorted({r["net"] for r in self._snap["copper"]} & set(nets))
        if not self.options.cleanup or not nets:  # a net without copper has nothing to prune
            return False
        drc = self.options.drc == "step"
        before = self._snap["clusters"]
        pruned = self._timed(self._session.prune, list(nets), drc)
        if not pruned["edits"]:
            return False
        self._took(pruned["snapshot"], pruned["edits"], drc)
        if operations.lost_connections(before, self._snap["clusters"], nets):
            self._apply(operations.undo(pruned["edits"]))
        return True

    def _took(self, snap: dict, edits: list[dict], drc: bool) -> None:
        """The worker's snapshot after it accepted `edits`."""
        self._snap = snap
        self._applied += edits
        self._drc_fresh = drc
        if drc:
            self._violations = canonical(self._snap["violations"])
        self._router_stale = True

    def _finish_step(self, rejected, router, changed):
        if changed:
            self._state = self._measure()
        terminated, truncated = self._end_flags()
        if (terminated or truncated) and not self._drc_fresh:
            try:  # drc="terminal": the final DRC, so the last reward carries the penalty
                self._final_drc()
            except EngineFailure as exc:
                return self._step_failed(str(exc))
            terminated, truncated = self._end_flags()
        return self._transition(terminated, truncated, rejected, router)

    def _transition(self, terminated: bool, truncated: bool, rejected, router, **extra):
        reward = self._telescope.reward(self._state["phi"], final=terminated or truncated)
        self._terminated, self._truncated = terminated, truncated
        self._ended = terminated or truncated
        self._refresh_masks()
        obs = self._observation()
        return obs, float(reward), terminated, truncated, \
            {**self._info(rejected=rejected, router=router), **extra}

    def finish_episode(self):
        """Ends the episode now (the agent has nothing left to do) and returns its last
        transition (obs, reward, terminated, truncated, info), as `step` would: the final DRC
        runs when the last one is stale (drc="terminal"), and the reward pays what is still
        owed (the DRC's correction; with reward="terminal", the whole Phi(s_T) - Phi(s_0)), so
        the episode's rewards sum to Phi(s_T) - Phi(s_0) of the board `save()` writes.
        Truncated (terminated if nothing is left unconnected); no step is counted and the
        board does not change. After the end, it changes nothing (reward 0)."""
        if self._ended or self.static is None:
            return self._after_end()
        if not self._drc_fresh:
            try:
                self._final_drc()
            except EngineFailure as exc:
                return self._step_failed(str(exc))
        terminated = self._state["unconnected"] == 0
        return self._transition(terminated, not terminated, None, None, finished_early=True)

    def _end_flags(self) -> tuple[bool, bool]:
        terminated = self._state["unconnected"] == 0
        return terminated, not terminated and self._step_no >= self.max_steps

    def _final_drc(self) -> None:
        self._snap = self._timed(self._session.snapshot, True)
        self._violations, self._drc_fresh = canonical(self._snap["violations"]), True
        self._state = self._measure()

    def _step_failed(self, reason: str):
        """A failure inside a step (KiCad refused an edit, crashed or timed out): the worker's
        board may be half-edited, so it is loaded again and given every edit it had accepted;
        the episode ends truncated on that last good board (saved and scored as usual), with
        the reason in `info["engine_failure"]`. If even that fails, `_engine_failed`."""
        try:
            self._timed(self._session.open, *self._files)
            self._snap = self._timed(self._session.apply, self._applied, True)
        except EngineFailure as exc:
            return self._engine_failed(f"{reason}; restoring the board failed too: {exc}")
        self._violations, self._drc_fresh = canonical(self._snap["violations"]), True
        self._router_stale = True
        self._state = self._measure()
        terminated = self._state["unconnected"] == 0
        return self._transition(terminated, not terminated, None, None, engine_failure=reason)

    def _engine_failed(self, reason: str):
        """A KiCad crash or time-out: the episode ends as truncated; reset() starts a fresh
        worker and reloads."""
        self._ended, self._terminated, self._truncated = True, False, True
        info = self._info(rejected=None, router=None)
        info["engine_failure"] = reason
        return self._observation(), 0.0, False, True, info

    # ---- observation and info ----------------------------------------------------------
    def _observation(self) -> dict:
        space = self.observation_space
        geometry, self._cut = observation.geometry_part(self.static, self._snap,
                                                        space["routing_geometry"])
        phase = masks.phase_of(self._net, self._head)
        return {"board_static": {k: v.copy() for k, v in self._static_obs.items()},
                "routing_geometry": geometry,
                "router_head": observation.head_part(self.static, phase, self._net, self._head,
                                                     self._cands, space["router_head"]),
                "drc": observation.drc_part(self.static, self._counted(), space["drc"]),
                "step": np.asarray(min(self._step_no, self.max_steps), dtype=np.int64)}

    def _info(self, rejected, router) -> dict:
        state = self._state
        return {"board_id": self.static.board_id, "step": self._step_no,
                "phase": PHASES[masks.phase_of(self._net, self._head)], "net": self._net,
                "rejected": rejected, "router": router, "unconnected": state["unconnected"],
                "drv": state["drv"], "phi": state["phi"], "wl_mm": state["wl"],
                "vias": state["via"], "counting": self.options.counting,
                "drc_fresh": self._drc_fresh, "engine": dict(ENGINE),
                "max_steps": self.max_steps,
                "action_mask": self.action_masks(), "masked_modes": dict(self._mode_reasons),
                "observation_cut": getattr(self, "_cut", False)}

    # ---- outputs -----------------------------------------------------------------------
    def save(self, path) -> str:
        """Writes the current board (the instance's own board with the agent's tracks and
        vias, saved by KiCad) as a `.kicad_pcb` that `pcbdata eval` scores."""
        if self._session is None:
            raise EnvValueError("nothing to save: call reset() first")
        return self._session.save(str(path))

    def render(self):
        """The current state as an RGB uint8 array (`pcbdata.core.drawing`; legend in
        docs/render.md), drawn from the data the environment holds; None without a render
        mode."""
        if self.render_mode is None:
            return None
        if self.static is None:
            raise EnvValueError("nothing to render: call reset() first")
        from pcbdata.core.drawing import draw_board

        records = state_records(self.static, self._snap, self._head, self._counted())
        return draw_board(records, RENDER_SIZE)

    @property
    def violations(self) -> list[dict] | None:
        """KiCad's DRC violations of the board as it stands (canonical order), less the
        warnings no counting counts (docs/env.md, "What the DRC holds"); None while the last
        DRC is older than the board (drc="terminal" mid-episode)."""
        return [dict(v) for v in self._violations] if self._drc_fresh else None

    @property
    def board_id(self) -> str | None:
        return self.static.board_id if self.static else None

    def close(self) -> None:
        if self._session is not None:
            self._session.close()
            self._session = None
        super().close()
