"""Router-found reference routings of a synthetic build (`pcbdata build d2r --reference-agent`).

For each board of the planned splits a worker task runs a bundled agent through the routing
environment, seeds 0..K-1, and keeps the first rollout the evaluator judges a clean pass, with
no DRC item of any severity left, as the board's `reference.kicad_pcb`. Nothing is filtered:
a board the agent does not complete stays in the set, without a reference and with the
reason, so the distribution of boards is the one the generator draws.

The task is named by the plan (`ReferencePlan.task`, filled by `pcbdata.runners.reference`),
so this layer runs the agents' code in workers without importing it.

Resumable: every final result (routed, not completed, refused by the build's KiCad check) is
logged in `DIR/.pcbdata/references.jsonl`, keyed by the board's instance files and the plan;
a build run again keeps a logged reference whose file is still in place and routes only the
rest. Engine failures (a worker's crash or time limit, an environment's engine failure) are
recorded in the manifest but not logged, so the next run tries those boards again.
"""
from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from pcbdata import __version__
from pcbdata.build.progress import Progress
from pcbdata.core.hashing import sha256_bytes, sha256_file
from pcbdata.core.textio import canonical_json
from pcbdata.core.tree import (
    INSTANCE_FILES,
    REFERENCE_FILE,
    board_dir,
    board_relpath,
    reference_log_path,
)
from pcbdata.executors import TaskPool

ROUTED = "routed"
NOT_COMPLETED = "not_completed"
ENGINE_FAILURE = "engine_failure"
CHECK_FAILED = "check_failed"
#: Results a run again keeps; an engine failure may not recur, so it is tried again.
FINAL = (ROUTED, NOT_COMPLETED, CHECK_FAILED)
#: Splits routed when the plan names none: the ones scored; 10,000 train boards take hours.
DEFAULT_SPLITS = ("validation", "test")

# (config, split, entry): a board of the build; `entry` is the build's mutable record of it.
Board = tuple[str, str, dict]


@dataclass(frozen=True)
class ReferencePlan:
    """How a build finds reference routings (plain data; `pcbdata.runners.reference.plan` makes
    it). `task` is the worker function ("module:function") that routes one board; `splits`
    None means `DEFAULT_SPLITS` among the splits being built; `env_options` are the routing
    environment's options besides its id, config, set and split; `env_version` the
    environment's version (a change of its dynamics routes the boards again)."""

    agent: str
    rollouts: int
    task: str
    env_version: int
    task_timeout: float
    splits: tuple[str, ...] | None = None
    env_options: dict = field(default_factory=dict)

    def routed_splits(self, built: list[str]) -> list[str]:
        wanted = DEFAULT_SPLITS if self.splits is None else self.splits
        return [split for split in built if split in wanted]

    def option(self) -> dict:
        """The option as the manifest records it per split."""
        return {"agent": self.agent, "rollouts": self.rollouts, "env_options": self.env_options,
                "env_version": self.env_version}


def board_key(plan: ReferencePlan, entry: dict) -> str:
    """What a result depends on: the instance's files, the plan and the package version."""
    files = {name: entry["files"].get(name) for name in INSTANCE_FILES}
    return sha256_bytes(canonical_json({"files": files, "plan": plan.option(),
                                        "package_version": __version__}).encode("utf-8"))


def board_record(plan: ReferencePlan, result: dict) -> dict:
    """The manifest's `reference_routing` entry of a board: where its reference came from, or
    why it has none. Every key is present on every board (null where it does not apply), so
    the published rows have one column per key."""
    return {"status": result["status"], "agent": plan.agent, "rollouts": plan.rollouts,
            "seed": result.get("seed"), "env_id": result.get("env_id"),
            "package_version": __version__, "reason": result.get("reason", "")}


def split_record(plan: ReferencePlan, entries: list[dict]) -> dict:
    """The manifest's `reference_routing` entry of a split: the option and the boards per
    status (`boards`: those the option applied to)."""
    per_status = counts(entries)
    return {**plan.option(), "boards": sum(per_status.values()), **per_status}


def counts(entries: list[dict]) -> dict[str, int]:
    """Boards per status among `entries` (those with a record)."""
    out = {status: 0 for status in (ROUTED, NOT_COMPLETED, ENGINE_FAILURE, CHECK_FAILED)}
    for entry in entries:
        record = entry.get("reference_routing")
        if record:
            out[record["status"]] += 1
    return out


class ReferenceLog:
    """Final results by board key (`board_key`); the last line of a key wins."""

    def __init__(self, root: Path):
        self.path = reference_log_path(root)
        self.results: dict[str, dict] = {}
        if self.path.exists():
            for line in self.path.read_text(encoding="utf-8").splitlines():
                try:
                    entry = json.loads(line)
                    self.results[entry["key"]] = entry["result"]
                except (json.JSONDecodeError, KeyError, TypeError):
                    continue  # a line cut short by a kill: that board is routed again

    def add(self, key: str, rel: str, result: dict) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path, "a", encoding="utf-8") as handle:
            handle.write(json.dumps({"key": key, "board": rel, "result": result},
                                    sort_keys=True) + "\n")
        self.results[key] = result


def _reference_path(root: Path, board: Board) -> Path:
    config, split, entry = board
    return board_dir(root, config, split, entry["board_id"]) / REFERENCE_FILE


def _apply(plan: ReferencePlan, entry: dict, result: dict) -> None:
    entry["reference_routing"] = board_record(plan, result)
    files = {k: v for k, v in entry["files"].items() if k != REFERENCE_FILE}
    if result["status"] == ROUTED:
        files[REFERENCE_FILE] = result["sha256"]
    entry["files"] = dict(sorted(files.items()))


def _remove(path: Path) -> None:
    if path.is_file():
        os.unlink(path)


def restore(root: Path, plan: ReferencePlan, boards: list[Board]) -> list[Board]:
    """Applies the logged results of `boards` to their entries; returns the boards to route.
    A reference file that no result vouches for (an earlier plan's, a killed run's) is removed,
    so a board never keeps a reference the manifest does not explain. Boards whose generator
    planted a reference (D1 random-walk) are left alone."""
    log = ReferenceLog(root)
    todo = []
    for board in boards:
        entry = board[2]
        if REFERENCE_FILE in entry["files"]:
            continue
        path = _reference_path(root, board)
        result = log.results.get(board_key(plan, entry))
        if result is not None and result["status"] == ROUTED and path.is_file() \
                and sha256_file(path) == result["sha256"]:
            _apply(plan, entry, result)
            continue
        _remove(path)
        if result is not None and result["status"] in (NOT_COMPLETED, CHECK_FAILED):
            _apply(plan, entry, result)
        else:
            todo.append(board)
    return todo


def route(root: Path, plan: ReferencePlan, boards: list[Board],
          pool_of: Callable[[int], TaskPool], workers: int) -> None:
    """Routes `boards` on a pool made by `pool_of(workers)` (one task per board) and applies
    each result as it comes: a worker that fails becomes the board's engine failure."""
    if not boards:
        return
    log = ReferenceLog(root)
    progress = Progress(f"reference routing ({plan.agent}, {plan.rollouts} rollouts)",
                        len(boards))
    tasks = [(str(root.resolve()), config, split, entry["board_id"], plan.agent, plan.rollouts,
              plan.env_options, str(_reference_path(root, (config, split, entry))))
             for config, split, entry in boards]
    with pool_of(max(1, min(workers, len(boards)))) as pool:
        for outcome in pool.map(plan.task, tasks):
            board = boards[outcome.index]
            result = outcome.value if outcome.ok else \
                {"status": ENGINE_FAILURE, "reason": f"engine failure: {outcome.error}"}
            result = _checked_file(root, board, result)
            _apply(plan, board[2], result)
            if result["status"] in FINAL:
                log.add(board_key(plan, board[2]), _rel(board), result)
            progress.advance()


def _checked_file(root: Path, board: Board, result: dict) -> dict:
    """A routed result whose file is not the bytes the worker reported is an engine failure."""
    path = _reference_path(root, board)
    if result["status"] != ROUTED:
        _remove(path)
        return result
    if not path.is_file() or sha256_file(path) != result.get("sha256"):
        _remove(path)
        return {**result, "status": ENGINE_FAILURE, "seed": None,
                "reason": "engine failure: the routed board was not written as reported"}
    return result


def refuse(root: Path, plan: ReferencePlan, board: Board, problem: str) -> None:
    """A routed reference that fails the build's KiCad check is dropped, logged as such and
    recorded with the reason: the board stays, without a reference (never a failed build)."""
    _remove(_reference_path(root, board))
    result = {"status": CHECK_FAILED, "env_id": board[2]["reference_routing"]["env_id"],
              "reason": f"routed, but the build's KiCad check found: {problem}"}
    _apply(plan, board[2], result)
    ReferenceLog(root).add(board_key(plan, board[2]), _rel(board), result)


def _rel(board: Board) -> str:
    config, split, entry = board
    return board_relpath(config, split, entry["board_id"])
