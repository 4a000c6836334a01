"""The paper's language-model protocol (SPEC 7.2) over the routing environment.

pcbdata's own protocol (`text`, `tools`, `wrapper`) shows candidate points with indices and
takes tool calls. This one is the paper's: the board as S-expressions with mm coordinates to
three decimals and episode-local ids (nets `N0`, pads `P0`, holes `H0`, tracks `T0`, vias
`V0`), no candidate list, the last two accepted turns, the rejected attempts since the last
accepted action, and replies `<think>...</think><action>BODY</action>` whose body is one of

    net_select <net_id> | net_end | start_route <x> <y> <layer> |
    make_line <x> <y> <mode> | make_via <x> <y> <mode> | finish <mode>

with free mm coordinates, layer 1 (F.Cu) or 2 (B.Cu) and mode m / p / w (`MODE_LETTERS`).
The actions go to the environment in its free-coordinate form (docs/env.md); everything
shown is read from the observation and `info` only, as ASCII.

`PaperSession(env)` keeps an episode: `reset()` gives the board's static text (for the
system message) and the first user message; `step(reply)` parses the reply, steps the
environment (a reply that cannot be read is an `idle` step) and returns the transition with
the turn's outcome; `counts` holds every way a reply became `idle`.
"""
from __future__ import annotations

import re
from collections import deque
from dataclasses import dataclass, field

from pcbdata.env.llm.text import mm, quote
from pcbdata.env.observation import PAD_SHAPES
from pcbdata.env.types import (
    FINISH,
    IDLE,
    MAKE_LINE,
    MAKE_VIA,
    MARK_OBSTACLES,
    NET_END,
    NET_SELECT,
    PHASES,
    PUSH_N_SHOVE,
    ROUTING,
    START_ROUTE,
    WALKAROUND,
)

#: The paper's mode letters as the environment's modes (SPEC 6): m mark_obstacles (pcbdata
#: lays the line and lets DRC mark the violations; the paper's aborts on a clearance
#: conflict), p push_n_shove, w walkaround.
MODE_LETTERS = {"m": MARK_OBSTACLES, "p": PUSH_N_SHOVE, "w": WALKAROUND}
LETTER_OF = {mode: letter for letter, mode in MODE_LETTERS.items()}
VERBS = ("net_select", "net_end", "start_route", "make_line", "make_via", "finish")
ARITY = {"net_select": 1, "net_end": 0, "start_route": 3, "make_line": 3, "make_via": 3,
         "finish": 1}
#: SPEC 7.2's expression for an action body (tokens joined by single spaces).
BODY = re.compile(r"^(net_select \S+|net_end|start_route -?\d+(\.\d+)? -?\d+(\.\d+)? [12]|"
                  r"(make_line|make_via) -?\d+(\.\d+)? -?\d+(\.\d+)? [mpw]|finish [mpw])$")
_NUMBER = re.compile(r"^-?\d+(\.\d+)?$")
_THINK = re.compile(r"<think>(.*?)</think>", re.DOTALL)
_ACTION = re.compile(r"<action>(.*?)</action>", re.DOTALL)
#: Every way a reply becomes `idle`, as counted in `PaperSession.counts` (`mask`: a body that
#: parsed but the environment's masks refused, or a net id no net has).
IDLE_KINDS = ("empty_reply", "non_ascii", "missing_action", "duplicate_action", "empty_action",
              "missing_think", "duplicate_think", "unknown_verb", "arity", "number",
              "bad_layer", "bad_mode", "mask")
#: The verbs whose effect the `[no effect]` tag judges (they are the ones that route).
ROUTING_VERBS = ("make_line", "make_via", "finish")
_INDENT = "  "


@dataclass(frozen=True)
class Reply:
    """A reply read: the think text, the action body (canonical: single spaces), the
    environment action (None when the reply becomes idle) and, when idle, why (`kind` one
    of `IDLE_KINDS`, `reason` one line)."""

    think: str
    body: str
    action: dict | None
    kind: str | None = None
    reason: str | None = None


class Ids:
    """Episode-local ids and layer tokens of one episode (from the reset's observation and
    `info`): nets `N<i>` (the environment's net index), pads `P<k>` (net pads in observation
    order), layers `1` (F.Cu), `2` (B.Cu), `in<k>` (inner layers, not routable here), `th`
    (a pad on both outer layers)."""

    def __init__(self, info: dict):
        self.net_names = list(info["net_names"])
        self.layers = list(info["layers"])
        self.back = len(self.layers) - 1  # B.Cu's index (F.Cu is 0)
        self.by_name = {name: i for i, name in enumerate(self.net_names)}

    def net(self, index) -> str:
        return f"N{int(index)}"

    def layer(self, index) -> str:
        i = int(index)
        if i == 0:
            return "1"
        return "2" if i == self.back else f"in{i}"

    def layer_index(self, token: str) -> int:
        return 0 if token == "1" else self.back

    def pad_layer(self, on) -> str:
        indices = [i for i, flag in enumerate(on[: len(self.layers)]) if flag]
        if 0 in indices and self.back in indices and self.back > 0:
            return "th"
        return " ".join(self.layer(i) for i in indices) or "none"

    def net_index(self, token: str) -> int | None:
        """The net an id (`N3`) or an exact net name names; None: no such net."""
        found = re.fullmatch(r"N(\d+)", token)
        if found and int(found.group(1)) < len(self.net_names):
            return int(found.group(1))
        return self.by_name.get(token)


def _xy(x, y) -> str:
    return f"{mm(x)} {mm(y)}"


def _block(head: str, items: list[str], depth: int = 1) -> str:
    if not items:
        return f"{_INDENT * depth}({head})"
    pad = _INDENT * (depth + 1)
    return f"{_INDENT * depth}({head}\n" + "\n".join(pad + i for i in items) + ")"


def net_pads(obs: dict) -> list[tuple[int, int]]:
    """(pad id number k of `P<k>`, row index) of the pads with a net, in observation order."""
    rows = obs["board_static"]["pads"]
    index = [i for i, row in enumerate(rows) if row[0] and int(row[1]) >= 0]
    return list(enumerate(index))


# ---- the board --------------------------------------------------------------------------
def board_static(obs: dict, info: dict, ids: Ids) -> str:
    """`board_static`: layers, the strictest constraints, outline, nets with their pads, pads
    (xy, layer, shape), drilled pads without a net as holes (obstacles); no widths."""
    s = obs["board_static"]
    return "\n".join([f"(board_static (board {quote(info['board_id'])})",
                      _layers(ids), _constraints(s, ids), _outline(s),
                      _nets(obs, ids), _pads(obs, ids), _holes(s) + ")"])


def _layers(ids: Ids) -> str:
    return _block("layers", [f"({ids.layer(i)} {name})" for i, name in enumerate(ids.layers)])


def _constraints(s: dict, ids: Ids) -> str:
    """The strictest effective values over the nets (largest clearance, track width, via
    diameter and drill) and the edge clearance; unset (zero) values are left out."""
    rows = s["nets"][: len(ids.net_names)]
    values = [("clearance", max((r[2] for r in rows), default=0.0)),
              ("track_width", max((r[3] for r in rows), default=0.0)),
              ("via_diameter", max((r[4] for r in rows), default=0.0)),
              ("via_drill", max((r[5] for r in rows), default=0.0)),
              ("edge_clearance", s["rules"][4])]
    shown = " ".join(f"({name} {mm(v)})" for name, v in values if v > 0)
    return f"{_INDENT}(board_constraints {shown})"


def _outline(s: dict) -> str:
    rows = s["outline"][: int(s["outline_count"])]
    rings = []
    for ring in sorted({int(r[2]) for r in rows}):
        rings.append("(ring " + " ".join(f"(point {_xy(r[0], r[1])})" for r in rows
                                           if int(r[2]) == ring) + ")")
    return _block("outline", rings)


def _nets(obs: dict, ids: Ids) -> str:
    pads = obs["board_static"]["pads"]
    members: dict[int, list[str]] = {}
    for k, i in net_pads(obs):
        members.setdefault(int(pads[i][1]), []).append(f"P{k}")
    return _block("nets", [f"(net {ids.net(n)} {quote(name)} (pads {' '.join(members.get(n, []))}))"
                           for n, name in enumerate(ids.net_names)])


def _pads(obs: dict, ids: Ids) -> str:
    s = obs["board_static"]
    items = []
    for k, i in net_pads(obs):
        row = s["pads"][i]
        code = int(row[6])
        shape = PAD_SHAPES[code].lower() if 0 <= code < len(PAD_SHAPES) else "other"
        items.append(f"(pad P{k} {ids.net(row[1])} (at {_xy(row[2], row[3])}) "
                     f"(layer {ids.pad_layer(s['pad_layers'][i])}) (shape {shape}))")
    return _block("pads", items)


def _holes(s: dict) -> str:
    rows = [r for r in s["pads"] if r[0] and int(r[1]) < 0 and r[7] > 0]
    return _block("holes", [f"(hole H{k} (at {_xy(r[2], r[3])}) (size {mm(max(r[4], r[5]))}))"
                            for k, r in enumerate(rows)])


def plan_board(obs: dict, info: dict, ids: Ids) -> str:
    """The plan-and-execute board: `(nets (net <id> "<name>" (pad <id> <x> <y> <tag>) ...))`
    with tag 1, 2 or th, after the layers, constraints and outline."""
    s = obs["board_static"]
    by_net: dict[int, list[str]] = {}
    for k, i in net_pads(obs):
        row = s["pads"][i]
        by_net.setdefault(int(row[1]), []).append(
            f"(pad P{k} {_xy(row[2], row[3])} {ids.pad_layer(s['pad_layers'][i])})")
    nets = []
    for n, name in enumerate(ids.net_names):
        pads = by_net.get(n, [])
        nets.append(f"(net {ids.net(n)} {quote(name)}\n{_INDENT * 3}"
                    + f"\n{_INDENT * 3}".join(pads) + ")")
    return "\n".join([f"(board {quote(info['board_id'])}", _layers(ids), _constraints(s, ids),
                      _outline(s), _block("nets", nets), _holes(s) + ")"])


def routing_geometry(obs: dict, ids: Ids) -> str:
    """Tracks (no widths), vias (no sizes), the ratsnest as `(point x y)` pairs without
    layers, and the count of unrouted connections."""
    geo = obs["routing_geometry"]
    tracks = [f"(track T{k} {ids.net(r[1])} (layer {ids.layer(r[2])}) "
              f"(from {_xy(r[4], r[5])}) (to {_xy(r[6], r[7])}))"
              for k, r in enumerate(geo["tracks"][: int(geo["track_count"])])]
    vias = [f"(via V{k} {ids.net(r[1])} (at {_xy(r[2], r[3])}))"
            for k, r in enumerate(geo["vias"][: int(geo["via_count"])])]
    edges = [f"(net {ids.net(r[1])} (point {_xy(r[2], r[3])}) (point {_xy(r[4], r[5])}))"
             for r in geo["ratsnest"][: int(geo["ratsnest_count"])]]
    return "\n".join(["(routing_geometry", _block("tracks", tracks), _block("vias", vias),
                      _block("ratsnest", edges),
                      f"{_INDENT}(unrouted {int(geo['unconnected'])}))"])


def router_head(obs: dict, ids: Ids, mode: str) -> str:
    head = obs["router_head"]
    phase = PHASES[int(head["phase"])]
    parts = [f"(phase {phase})"]
    if int(head["net"]) >= 0:
        parts.append(f"(net {ids.net(head['net'])})")
    if int(head["layer"]) >= 0:
        x, y = head["position"]
        parts += [f"(at {_xy(x, y)})", f"(layer {ids.layer(head['layer'])})"]
    parts.append(f"(mode {mode})")
    return f"(router_head {' '.join(parts)})"


# ---- replies ------------------------------------------------------------------------------
def read_reply(reply, ids: Ids, require_think: bool = True) -> Reply:
    """The reply as an action, or why it becomes idle (never raises)."""
    if not isinstance(reply, str) or not reply.strip():
        return Reply("", "", None, "empty_reply", "empty reply")
    bad = next((c for c in reply if ord(c) > 127), None)
    if bad is not None:
        return Reply("", "", None, "non_ascii", f"non-ASCII character U+{ord(bad):04X}")
    actions = list(_ACTION.finditer(reply))
    if not actions:
        return Reply("", "", None, "missing_action", "no <action>...</action>")
    if len(actions) > 1:
        return Reply("", "", None, "duplicate_action", f"{len(actions)} <action> elements")
    body = " ".join(actions[0].group(1).split())
    thinks = list(_THINK.finditer(reply))
    think = thinks[0].group(1).strip() if thinks else ""
    if not body:
        return Reply(think, "", None, "empty_action", "empty <action>")
    if require_think and not thinks:
        return Reply("", body, None, "missing_think", "no <think>...</think>")
    if require_think and len(thinks) > 1:
        return Reply(think, body, None, "duplicate_think", f"{len(thinks)} <think> elements")
    if require_think and thinks[0].start() > actions[0].start():
        return Reply(think, body, None, "missing_think", "no <think> before the <action>")
    return read_body(body, ids, think)


def read_body(body: str, ids: Ids, think: str = "") -> Reply:
    """One action body (`make_line 12.345 6.789 w`) as an environment action, or idle."""
    body = " ".join(body.split())
    tokens = body.split(" ") if body else [""]
    verb, args = tokens[0], tokens[1:]
    if verb not in ARITY:
        return Reply(think, body, None, "unknown_verb", f"unknown verb {verb[:30]!r}")
    if len(args) != ARITY[verb]:
        return Reply(think, body, None, "arity", f"{verb} takes {ARITY[verb]} argument(s), got "
                                                 f"{len(args)}")
    if verb in ("start_route", "make_line", "make_via"):
        if not all(_NUMBER.match(a) for a in args[:2]):
            return Reply(think, body, None, "number", f"{verb}: x and y must be mm decimals")
    if verb == "start_route" and args[2] not in ("1", "2"):
        return Reply(think, body, None, "bad_layer", f"start_route: layer must be 1 or 2, got "
                                                     f"{args[2][:10]!r}")
    if verb in ("make_line", "make_via", "finish") and args[-1] not in MODE_LETTERS:
        return Reply(think, body, None, "bad_mode", f"{verb}: mode must be m, p or w, got "
                                                    f"{args[-1][:10]!r}")
    assert BODY.match(body), body
    action: dict = {"type": IDLE}
    if verb == "net_select":
        net = ids.net_index(args[0])
        if net is None:
            return Reply(think, body, None, "mask", f"net_select: no net {args[0][:40]!r}")
        action = {"type": NET_SELECT, "net": net}
    elif verb == "net_end":
        action = {"type": NET_END}
    elif verb == "finish":
        action = {"type": FINISH, "mode": MODE_LETTERS[args[0]]}
    else:
        action = {"type": {"start_route": START_ROUTE, "make_line": MAKE_LINE,
                           "make_via": MAKE_VIA}[verb], "x": float(args[0]), "y": float(args[1])}
        if verb == "start_route":
            action["layer"] = ids.layer_index(args[2])
        else:
            action["mode"] = MODE_LETTERS[args[2]]
    return Reply(think, body, action)


def action_body(action: dict, ids: Ids, obs: dict | None = None) -> str:
    """An environment action (index or free-coordinate form) as an action body, the inverse
    of `read_body` (an index action's point is read from `obs`'s candidates)."""
    kind = int(action["type"])
    letter = LETTER_OF[int(action.get("mode", WALKAROUND))]
    if kind == NET_SELECT:
        return f"net_select {ids.net(action['net'])}"
    if kind == NET_END:
        return "net_end"
    if kind == FINISH:
        return f"finish {letter}"
    if "x" in action:
        x, y, layer = action["x"], action["y"], action.get("layer", 0)
    else:
        assert obs is not None, "an index action needs the observation of its step"
        c = obs["router_head"]["candidates"][int(action["candidate"])]
        x, y, layer = c[1], c[2], int(c[3])
    if kind == START_ROUTE:
        return f"start_route {_xy(x, y)} {'1' if int(layer) == 0 else '2'}"
    verb = "make_line" if kind == MAKE_LINE else "make_via"
    return f"{verb} {_xy(x, y)} {letter}"


# ---- the session --------------------------------------------------------------------------
@dataclass
class Turn:
    """An accepted turn as the history shows it."""

    step: int
    think: str
    body: str
    tags: list[str] = field(default_factory=list)

    def text(self) -> str:
        tags = "".join(f" {t}" for t in self.tags)
        return f"Step {self.step}: <think>{self.think}</think><action>{self.body}</action>{tags}"


@dataclass
class Rejected:
    """Rejected attempts with one body, merged: steps first..last, count."""

    first: int
    last: int
    body: str
    count: int = 1

    def text(self) -> str:
        steps = f"{self.first}" if self.first == self.last else f"{self.first}-{self.last}"
        return f"Step {steps}: {self.body} (rejected x{self.count})"


@dataclass(frozen=True)
class Outcome:
    """What came of one reply: `accepted` (parsed and mask-valid), the idle `kind` and reason
    otherwise, and whether the `[no effect]` tag was given."""

    step: int
    body: str
    accepted: bool
    kind: str | None
    reason: str | None
    no_effect: bool


class PaperSession:
    """One episode of the paper's protocol over a routing environment (`gym.make(...)`).

    `history`: accepted turns shown (2); `no_effect`: which accepted actions the `[no effect]`
    tag judges, `routing` (make_line, make_via, finish; the start_route right before a tagged
    one is tagged too) or `all` (every accepted action that leaves the count of unrouted
    connections as it was); `require_think`: a reply without exactly one `<think>` before its
    `<action>` is idle (the paper's rule)."""

    def __init__(self, env, history: int = 2, no_effect: str = "routing",
                 require_think: bool = True):
        if no_effect not in ("routing", "all"):
            raise ValueError(f"no_effect={no_effect!r}: routing or all")
        self.env, self.history_size = env, history
        self.no_effect, self.require_think = no_effect, require_think

    def reset(self, seed=None, options=None) -> tuple[str, str, dict]:
        """(board_static text, first user message, info)."""
        obs, info = self.env.reset(seed=seed, options=options)
        self.ids = Ids(info)
        self.obs, self.info = obs, info
        self.static = board_static(obs, info, self.ids)
        self.turn, self.valid, self.mode = 0, 0, "w"
        self.history: deque[Turn] = deque(maxlen=max(self.history_size, 0))
        self.last_accepted: Turn | None = None
        self.rejected: list[Rejected] = []
        self.counts = dict.fromkeys(("turns", "accepted", "no_effect", *IDLE_KINDS), 0)
        self.outcomes: list[Outcome] = []
        return self.static, self.user_message(), info

    def step(self, reply):
        """(reward, terminated, truncated, info, outcome) of one reply."""
        return self._step(read_reply(reply, self.ids, self.require_think))

    def step_body(self, body: str):
        """`step` for a bare action body (a plan's line: no think, no tags)."""
        return self._step(read_body(body, self.ids))

    def _step(self, parsed: Reply):
        self.turn += 1
        self.counts["turns"] += 1
        before = int(self.info["unconnected"])
        action = parsed.action if parsed.action is not None else {"type": IDLE}
        obs, reward, terminated, truncated, info = self.env.step(action)
        kind, reason = parsed.kind, parsed.reason
        if kind is None and info.get("rejected"):
            kind, reason = "mask", str(info["rejected"])
        no_effect = False
        if kind is None:
            no_effect = self._accept(parsed, before, int(info["unconnected"]))
        else:
            self.counts[kind] += 1
            self._reject(parsed.body or f"[{kind.replace('_', ' ')}]")
        self.obs, self.info = obs, info
        outcome = Outcome(self.turn, parsed.body, kind is None, kind, reason, no_effect)
        self.outcomes.append(outcome)
        return reward, terminated, truncated, info, outcome

    def finish_episode(self):
        obs, reward, terminated, truncated, info = self.env.unwrapped.finish_episode()
        self.obs, self.info = obs, info
        return reward, terminated, truncated, info

    def _accept(self, parsed: Reply, before: int, after: int) -> bool:
        self.valid += 1
        self.counts["accepted"] += 1
        self.rejected = []
        verb = parsed.body.split(" ")[0]
        if verb in ROUTING_VERBS:
            self.mode = parsed.body.split(" ")[-1]
        turn = Turn(self.turn, parsed.think, parsed.body)
        judged = self.no_effect == "all" or verb in ROUTING_VERBS
        no_effect = judged and before == after
        if no_effect:
            turn.tags.append("[no effect]")
            self.counts["no_effect"] += 1
            wasted = self.last_accepted
            if (verb in ROUTING_VERBS and wasted is not None
                    and wasted.body.startswith("start_route") and not wasted.tags):
                wasted.tags.append("[no effect]")
        self.history.append(turn)
        self.last_accepted = turn
        return no_effect

    def _reject(self, body: str) -> None:
        for entry in self.rejected:
            if entry.body == body:
                entry.last, entry.count = self.turn, entry.count + 1
                return
        self.rejected.append(Rejected(self.turn, self.turn, body))

    # ---- messages ---------------------------------------------------------------------------
    def valid_verbs(self) -> list[str]:
        """The verbs the phase allows (from the masks; start_route by coordinates also while
        routing)."""
        mask = self.info["action_mask"]["type"]
        phase = PHASES.index(self.info["phase"])
        verbs = [v for v, t in (("net_select", NET_SELECT), ("net_end", NET_END),
                                ("start_route", START_ROUTE), ("make_line", MAKE_LINE),
                                ("make_via", MAKE_VIA), ("finish", FINISH)) if mask[t]]
        if phase == ROUTING:
            verbs = [v for v in VERBS if v in verbs or v in ("start_route", "make_line")]
        return verbs

    def user_message(self) -> str:
        """## Step, the observation (routing_geometry, router_head), the history, the rejected
        attempts and the valid verbs."""
        step = self.turn + 1
        lines = [f"## Step {step}", routing_geometry(self.obs, self.ids),
                 router_head(self.obs, self.ids, self.mode),
                 f"## History (step {step}, valid steps {self.valid})"]
        lines += [t.text() for t in self.history] or ["(none)"]
        lines.append("## Rejected attempts")
        lines += [r.text() for r in self.rejected] or ["(none)"]
        lines.append("## Valid actions")
        lines.append(", ".join(self.valid_verbs()) or "none")
        lines.append("Choose exactly one valid action; reply <think>...</think> then "
                     "<action>...</action>.")
        return "\n".join(lines)
