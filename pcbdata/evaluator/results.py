"""`results.json`: one evaluation as a file anyone can check and compare (schema
`pcbdata-results-1`, shipped as `pcbdata/resources/results.schema.json`).

It names the set, the evaluator, KiCad, the agent, the budgets and the seeds, lists every
board's rollouts with their figures (SPEC 4), DRC errors by type, time and tokens, and the
aggregates @1 and @k. Every figure of a board and every aggregate derives from the rollouts'
figures (`derive`), so a file whose figures disagree with its own rollouts is caught without
KiCad (`pcbdata leaderboard`), and one whose rollouts disagree with its boards by rescoring.
What the rollouts' JSON files do not record (older runs) is null, never guessed. Only
`machine` (the machine that evaluated, and its load) may differ between two evaluations of
the same runs.
"""
from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Iterable
from importlib import resources
from pathlib import Path

from pcbdata.core.errors import UserError
from pcbdata.core.machine import machine_info
from pcbdata.evaluator.protocol import board_row, summarize
from pcbdata.evaluator.scorer import EVALUATOR_VERSION, failed_record

SCHEMA_ID = "pcbdata-results-1"
SCHEMA_FILE = "results.schema.json"
RESULTS_FILE = "results.json"
#: The figures of the @1 and @k aggregates.
FIGURES = ("cp", "pot", "rout", "drv", "wl", "via")
#: What a rollout entry keeps of its record (besides name, index, time, tokens, ...).
ROLLOUT_FIELDS = ("status", "reason", "cp", "cp_strict", "pot", "pot_evaluation", "rout", "drv",
                  "drv_strict", "unconnected", "wl", "via", "penalty", "phi", "phi_bare",
                  "net_count", "drv_by_type", "drv_strict_by_type", "sha256")
#: A board's figures, all taken from its kept rollout (`runs.board_row`).
BOARD_FIELDS = ("best_rollout", "n_rollouts", "parse_fail", "cp", "pot", "rout", "drv",
                "unconnected", "wl", "via", "cp_strict", "drv_strict", "pot_evaluation", "time")
AGENT_FIELDS = ("name", "version", "checkpoint_sha256", "model", "base_url", "prompt_version",
                "sampling")
BUDGET_FIELDS = ("max_steps", "drc", "time_limit_s")
Reader = Callable[[Path], tuple[object, str]]


def schema() -> dict:
    """The JSON Schema of results files."""
    text = (resources.files("pcbdata.resources") / SCHEMA_FILE).read_text(encoding="utf-8")
    return json.loads(text)


def schema_problem(data: object) -> str | None:
    """Why `data` is not a valid results file (the first violation, one line), or None."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema())
    error = jsonschema.exceptions.best_match(validator.iter_errors(data))
    if error is None:
        return None
    where = "/".join(str(p) for p in error.absolute_path) or "(top level)"
    return f"{where}: {error.message}".replace("\n", " ")[:300]


# ---- from the rollouts' JSON files -------------------------------------------------------

def _sidecar(board_file: Path, read: Reader) -> dict:
    """A rollout's JSON as a dict ({} when there is none or it cannot be read)."""
    path = board_file.with_suffix(".json")
    if not path.is_file():
        return {}
    data, problem = read(path)
    return data if isinstance(data, dict) and not problem else {}


def _integer(value) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) else None


def _number(value) -> float | None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    return value if ok else None


def _tokens(sidecar: dict) -> dict | None:
    llm = sidecar.get("llm")
    accounting = llm.get("accounting") if isinstance(llm, dict) else None
    if not isinstance(accounting, dict):
        return None
    return {"prompt": _integer(accounting.get("prompt_tokens")),
            "completion": _integer(accounting.get("completion_tokens"))}


def _agent_of(sidecar: dict) -> dict:
    """The agent identity a rollout records: `agent_identity`, else only the name of an older
    rollout JSON's `agent` string."""
    identity = sidecar.get("agent_identity")
    if isinstance(identity, dict):
        return {key: identity.get(key) for key in AGENT_FIELDS}
    name = sidecar.get("agent")
    return {key: (name if key == "name" and isinstance(name, str) else None)
            for key in AGENT_FIELDS}


def _env_of(sidecar: dict) -> tuple[str | None, int | None]:
    """(environment id, version): `env_version`, else the id's `-vN` suffix."""
    env_id = sidecar.get("env_id") if isinstance(sidecar.get("env_id"), str) else None
    version = _integer(sidecar.get("env_version"))
    if version is None and env_id is not None:
        found = re.search(r"-v(\d+)$", env_id)
        version = int(found.group(1)) if found else None
    return env_id, version


def _agreed(values: list) -> object:
    """The value every rollout records, or None (not recorded by all, or not the same)."""
    if not values or any(v is None for v in values):
        return None
    first = json.dumps(values[0], sort_keys=True)
    return values[0] if all(json.dumps(v, sort_keys=True) == first for v in values) else None


def _budget(sidecar: dict, key: str) -> object:
    budgets = sidecar.get("budgets")
    return budgets.get(key) if isinstance(budgets, dict) else None


def rollout_entry(row: dict, sidecar: dict) -> dict:
    """One rollout of a board: its figures, DRC errors by type, time, tokens, seed, step
    limit and the load of the machine it ran on (from its JSON; None where not recorded)."""
    machine = sidecar.get("machine")
    load = machine.get("load") if isinstance(machine, dict) else None
    entry = {"rollout": row["rollout"], "index": row["index"],
             **{key: row.get(key) for key in ROLLOUT_FIELDS},
             "time": row.get("time"), "tokens": _tokens(sidecar),
             "seed": _integer(sidecar.get("seed")),
             "step_limit": _integer(_budget(sidecar, "step_limit")),
             "load": _number(load[0]) if isinstance(load, list) and load else None}
    entry["drv_by_type"] = entry["drv_by_type"] or {}
    entry["drv_strict_by_type"] = entry["drv_strict_by_type"] or {}
    entry["reason"] = entry["reason"] or ""
    entry["sha256"] = entry["sha256"] or None
    return entry


def submission_facts(sidecars: list[dict], reference: bool) -> dict:
    """`agent`, `env_id`, `budgets` (without k) and `seeds` of a submission, from its
    rollouts' JSON files: a field is given when every rollout records it alike, else null."""
    if reference:
        return {"agent": {key: ("reference" if key == "name" else None) for key in AGENT_FIELDS},
                "env_id": {"id": None, "version": None},
                "budgets": dict.fromkeys(BUDGET_FIELDS), "seeds": None}
    agents = [_agent_of(s) for s in sidecars]
    envs = [_env_of(s) for s in sidecars]
    seeds = sorted({s["seed"] for s in sidecars if _integer(s.get("seed")) is not None})
    return {"agent": {key: _agreed([a[key] for a in agents]) for key in AGENT_FIELDS},
            "env_id": {"id": _agreed([e[0] for e in envs]),
                       "version": _agreed([e[1] for e in envs])},
            "budgets": {key: _agreed([_budget(s, key) for s in sidecars])
                        for key in BUDGET_FIELDS},
            "seeds": seeds or None}


# ---- figures derived from the rollouts ----------------------------------------------------

def _mean(values: Iterable) -> float | None:
    known = [v for v in values if v is not None]
    return math.fsum(known) / len(known) if known else None


def _std(values: list) -> float | None:
    """Sample standard deviation (n - 1) of the known values; None for fewer than two."""
    known = [v for v in values if v is not None]
    if len(known) < 2:
        return None
    mean = math.fsum(known) / len(known)
    return math.sqrt(math.fsum((v - mean) ** 2 for v in known) / (len(known) - 1))


def _quantile(ordered: list[float], q: float) -> float:
    """Linear interpolation between the closest ranks (numpy's default)."""
    position = q * (len(ordered) - 1)
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def time_figures(times: list) -> dict:
    """Mean, median, 95th percentile and maximum of the rollouts' times (null without any)."""
    known = sorted(t for t in times if t is not None)
    if not known:
        return {"n": 0, "mean": None, "median": None, "p95": None, "max": None}
    return {"n": len(known), "mean": _mean(known), "median": _quantile(known, 0.5),
            "p95": _quantile(known, 0.95), "max": known[-1]}


def _set_figures(board_rows: list[dict], k: int) -> dict:
    summary = summarize(board_rows, [], k)
    return {key: summary[key] for key in FIGURES}


def _at_1_rows(boards: list[dict], index: int) -> list[dict]:
    """Board rows from rollout `index` alone: a board without one counts as missing."""
    rows = []
    for board in boards:
        taken = [r for r in board["rollouts"] if r["index"] == index]
        if not taken:
            taken = [{**failed_record("parse_fail", "missing"), "rollout": "missing",
                      "index": index}]
        rows.append(board_row(board["board_id"], taken))
    return rows


def aggregates(boards: list[dict], k: int) -> dict:
    """@k: the set's figures on each board's kept rollout (one figure, no spread here). @1:
    the set's figures on rollout index r alone, for every r any board has; mean and sample
    std over those figures. Time over every rollout's time; tokens summed."""
    kept = [board_row(b["board_id"], b["rollouts"]) for b in boards]
    at_k = _set_figures(kept, k)
    indices = sorted({r["index"] for b in boards for r in b["rollouts"]})
    per_index = [_set_figures(_at_1_rows(boards, i), 1) for i in indices]
    rollouts = [r for b in boards for r in b["rollouts"]]
    return {"at_k": {"k": k, **{key: {"mean": at_k[key], "std": None} for key in FIGURES}},
            "at_1": {"n": len(indices),
                     **{key: {"mean": _mean(f[key] for f in per_index),
                              "std": _std([f[key] for f in per_index])} for key in FIGURES}},
            "time": time_figures([r["time"] for r in rollouts]),
            "tokens": _token_totals(rollouts)}


def _token_totals(rollouts: list[dict]) -> dict | None:
    counted = [r["tokens"] for r in rollouts if r["tokens"] is not None]
    if not counted:
        return None
    return {"rollouts": len(counted),
            **{key: sum(t[key] or 0 for t in counted) for key in ("prompt", "completion")}}


def board_entry(board_id: str, rollouts: list[dict]) -> dict:
    """A board: the figures of its kept rollout (`runs.board_row`) and its rollouts."""
    row = board_row(board_id, rollouts)
    return {"board_id": board_id, **{key: row[key] for key in BOARD_FIELDS},
            "rollouts": rollouts}


def derive(data: dict) -> dict:
    """The boards' figures and the aggregates as the file's own rollouts give them."""
    boards = [board_entry(b["board_id"], b["rollouts"]) for b in data["boards"]]
    return {"boards": boards, "aggregates": aggregates(boards, data["budgets"]["k"])}


# ---- the file -----------------------------------------------------------------------------

def build(summary: dict, label: str, rollout_rows: list[dict], board_files: list[Path],
          read: Reader, context: dict) -> dict:
    """The results file of one evaluation. `board_files` are the rollouts' files (in the
    order of `rollout_rows`); `context` holds `set_folder`, `runs` (None for --reference),
    `kicad_version` and `pcbdata_version`."""
    reference = context["runs"] is None
    sidecars = [{} if reference else _sidecar(path, read) for path in board_files]
    by_board: dict[str, list[dict]] = {}
    for row, sidecar in zip(rollout_rows, sidecars, strict=True):
        by_board.setdefault(row["board_id"], []).append(rollout_entry(row, sidecar))
    boards = [board_entry(board_id, rollouts) for board_id, rollouts in by_board.items()]
    recorded = [s for s, row in zip(sidecars, rollout_rows) if row["rollout"] != "missing"]
    facts = submission_facts(recorded, reference)
    folder = Path(context["set_folder"]).resolve()
    return {"schema": SCHEMA_ID, "method": label,
            "set": {**summary["set"], "name": folder.name, "folder": str(folder)},
            "evaluator_version": EVALUATOR_VERSION, "kicad_version": context["kicad_version"],
            "pcbdata_version": context["pcbdata_version"],
            "convention": summary["convention"], "weights": summary["weights"],
            "reference": reference, "env_id": facts["env_id"], "agent": facts["agent"],
            "budgets": {"k": summary["k"], **facts["budgets"]}, "seeds": facts["seeds"],
            "runs": None if reference else str(Path(context["runs"]).resolve()),
            "machine": machine_info(), "n_boards": len(boards), "boards": boards,
            "aggregates": aggregates(boards, summary["k"])}


def results_text(data: dict) -> str:
    return json.dumps(data, indent=1, sort_keys=True) + "\n"


def read_results(path: Path) -> dict:
    """A results file, valid against the schema; else a UserError naming the file."""
    try:
        data = json.loads(Path(path).read_bytes().decode("utf-8"))
    except OSError as exc:
        raise UserError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise UserError(f"{path}: not UTF-8 text") from None
    except ValueError as exc:
        raise UserError(f"{path}: not valid JSON ({str(exc).splitlines()[0][:80]})") from None
    except RecursionError:
        raise UserError(f"{path}: JSON nested too deeply to read") from None
    if isinstance(data, dict) and data.get("schema") not in (None, SCHEMA_ID):
        raise UserError(f"{path}: schema {str(data.get('schema'))[:40]!r}, this pcbdata reads "
                        f"{SCHEMA_ID}")
    problem = schema_problem(data)
    if problem:
        raise UserError(f"{path}: not a valid {SCHEMA_ID} file ({problem})")
    return data
