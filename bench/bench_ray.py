"""Benchmark: the Ray executor on a local Ray cluster versus the local executor.

Same machine, same work, one run each, in this order:

1. empty tasks (`os:getpid`): the cost of one task round trip through each executor;
2. a D2 build (train split, `--boards` boards, 128 of them checked in KiCad, no publishing):
   generation chunks of 128 boards + KiCad checks; the manifests must be the same bytes;
   publishing (parquet shards, card, pictures) is timed once: it runs on the driver whatever
   the executor;
3. `pcbdata eval` of D2 rollouts (`--eval-boards` test boards x 5 rollouts with straight
   tracks: shorts, clearance violations and unconnected items); the reports must be the same;
4. `pcbdata rollout` of the scripted agent (`--rollout-boards` D2 test boards x 1 rollout, DRC
   after every step): one task per rollout; the files must be the same but for `time_s`;
5. environment actors (`pcbdata.runners.ray_actors`): the same scripted episodes stepped from the
   driver on one actor per CPU (`step_episodes`, one round trip per step) against one local
   environment (`run_episodes`); the episode records must be the same.

For each: wall seconds, the driver's own CPU seconds (this process, not its workers: what a
bigger cluster would wait on) and the overhead of Ray per task. The local cluster has as many
CPUs as the machine; the local executor runs as many workers (the evaluator's own default of
8 per core is timed too).

    .venv/bin/python bench/bench_ray.py --boards 10000 --eval-boards 128 --json bench-ray.json
    .venv/bin/python bench/bench_ray.py --parts rollout,actors --json bench-ray-rollout.json
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # loopback only
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

from _measure import machine  # noqa: E402

from pcbdata.build import SyntheticOptions, build_level  # noqa: E402
from pcbdata.executors import LOCAL, RayExecutor  # noqa: E402

REPORT_FILES = ("per_rollout.csv", "per_board.csv", "summary.json", "summary.md")


def driver_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def timed(function) -> tuple[object, float, float]:
    wall, cpu = time.perf_counter(), driver_cpu()
    value = function()
    return value, time.perf_counter() - wall, driver_cpu() - cpu


def empty_tasks(executor, workers: int, count: int) -> dict:
    with executor.pool(workers=workers, task_timeout=60) as pool:
        list(pool.map("os:getpid", [()] * workers))  # start the workers first
        _, wall, cpu = timed(lambda: list(pool.map("os:getpid", [()] * count)))
    return {"tasks": count, "seconds": wall, "driver_cpu": cpu}


def build(out: Path, executor, workers: int, boards: int) -> dict:
    options = SyntheticOptions(splits=["train"], count=boards, workers=workers, publish=False,
                               log=lambda line: None, executor=executor)
    summary, wall, cpu = timed(lambda: build_level(out, "d2", options=options))
    return {"boards": boards, "checked": summary.checked, "seconds": wall, "driver_cpu": cpu}


def make_rollouts(root: Path, runs: Path, boards: int) -> int:
    from pcbdata.model.kicad_writer import board_files
    from pcbdata.sets.configs import get_config
    from pcbdata.testing.drc import with_straight_tracks

    spec = get_config("d2")
    generator, count = spec.generator(), 0
    for index in range(boards):
        instance = generator.generate(spec.seed, "test", index)
        folder = runs / instance.board_id
        folder.mkdir(parents=True)
        for rollout, every in enumerate((2, 3, 4, 5, 99)):
            routed = with_straight_tracks(instance.board, unrouted_every=every)
            (folder / f"{rollout}.kicad_pcb").write_text(board_files(routed)["board.kicad_pcb"])
            (folder / f"{rollout}.json").write_text('{"time_s": 1.0}')
            count += 1
    return count


def evaluate(root: Path, runs: Path, out: Path, executor, workers: int) -> dict:
    from pcbdata.evaluator.runs import evaluate_set

    result, wall, cpu = timed(lambda: evaluate_set(
        root, "d2", "test", out, runs=runs, k=5, workers=workers, progress=False,
        executor=executor))
    return {"rollouts": result["summary"]["n_rollouts"], "seconds": wall, "driver_cpu": cpu,
            "report": {f: (out / f).read_bytes() for f in REPORT_FILES}}


def rollout(root: Path, out: Path, executor, workers: int, boards: int) -> dict:
    from pcbdata.runners.rollout import run_rollouts

    summary, wall, cpu = timed(lambda: run_rollouts(
        root, "d2", "test", "scripted", 1, out, workers, limit=boards, log=lambda line: None,
        executor=executor))
    return {"rollouts": summary["run"], "failed": summary["failed"], "seconds": wall,
            "driver_cpu": cpu, "episode_s": summary["mean_time_s"]}


def rollout_files(runs: Path) -> str:
    """Every file of RUNS, the JSON without its wall time (`time_s`), as one comparable text."""
    files = {}
    for path in sorted(runs.rglob("*")):
        if path.is_file():
            text = path.read_bytes()
            if path.suffix == ".json":
                record = json.loads(text)
                record.pop("time_s")
                text = json.dumps(record, sort_keys=True).encode()
            files[str(path.relative_to(runs))] = text.hex()
    return json.dumps(files, sort_keys=True)


def actors(root: Path, cores: int, boards: int) -> dict:
    """The same scripted episodes: on `cores` actors from the driver, and on one local env."""
    import gymnasium as gym
    import ray

    from pcbdata.agents.scripted import ScriptedAgent
    from pcbdata.runners.ray_actors import close_actors, make_actors, run_episodes, step_episodes

    specs = [(f"board_{i:05d}", 0) for i in range(boards)]
    options = {"root": str(root), "split": "test"}
    idle = {"type": 0, "net": 0, "candidate": 0, "mode": 0}
    env = gym.make("pcbdata/Route-d2-v2", **options)
    try:
        local, wall, cpu = timed(lambda: run_episodes(env, ScriptedAgent, specs))
        env.reset(seed=0, options={"index": 0})
        _, idle_local, _ = timed(lambda: [env.step(idle) for _ in range(IDLE_STEPS)])
    finally:
        env.close()
    handles = make_actors(cores, "pcbdata/Route-d2-v2", **options)
    try:
        ray.get([a.reset.remote(seed=0, options={"index": 0}) for a in handles])  # warm
        _, idle_actor, _ = timed(lambda: [ray.get(handles[0].step.remote(idle))
                                          for _ in range(IDLE_STEPS)])
        remote, rwall, rcpu = timed(lambda: step_episodes(handles, ScriptedAgent, specs))
    finally:
        close_actors(handles)
    steps = sum(e.steps for e in local)
    return {"episodes": boards, "steps": steps, "actors": cores,
            "local_one_env": {"seconds": wall, "driver_cpu": cpu},
            "ray_actors": {"seconds": rwall, "driver_cpu": rcpu},
            "idle_step_ms": {"local": idle_local / IDLE_STEPS * 1000,
                             "actor": idle_actor / IDLE_STEPS * 1000},
            "same_episodes": [vars(e) for e in local] == [vars(e) for e in remote]}


#: Idle steps (no KiCad call) timed one by one: the cost of a step's round trip to an actor.
IDLE_STEPS = 100


def rollout_parts(figures: dict, parts: set[str], tmp_path: Path, on_ray, cores: int,
                  boards: int) -> None:
    root = tmp_path / "rollout-set"
    build_level(root, "d2", options=SyntheticOptions(splits=["test"], count=boards, workers=cores,
                                            publish=False, log=lambda line: None))
    figures["rollout_boards"] = boards
    if "rollout" in parts:
        figures["rollout"] = {name: rollout(root, tmp_path / f"runs-{name}", ex, cores, boards)
                              for name, ex in (("local", LOCAL), ("ray", on_ray))}
        texts = {rollout_files(tmp_path / f"runs-{n}") for n in ("local", "ray")}
        figures["rollout"]["same_files_but_time_s"] = len(texts) == 1
        print(json.dumps(figures["rollout"], indent=1), flush=True)
    if "actors" in parts:
        figures["actors"] = actors(root, cores, boards)
        print(json.dumps(figures["actors"], indent=1), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boards", type=int, default=10_000, help="D2 train boards to build")
    parser.add_argument("--eval-boards", type=int, default=128,
                        help="D2 test boards to score, 5 rollouts each")
    parser.add_argument("--empty", type=int, default=2000, help="empty tasks per executor")
    parser.add_argument("--rollout-boards", type=int, default=32,
                        help="D2 test boards for the rollout and actor runs, 1 episode each")
    parser.add_argument("--parts", default="empty,build,eval,rollout,actors",
                        help="which runs, comma-separated (default: all)")
    parser.add_argument("--json", help="write the figures here")
    parser.add_argument("--project", metavar="JSON",
                        help="only print the projection from figures saved by --json")
    args = parser.parse_args()
    if args.project:
        print(projection(json.loads(Path(args.project).read_text())))
        return
    import ray

    parts = set(args.parts.split(","))
    cores = os.cpu_count() or 1
    load = os.getloadavg()
    ray_start = time.perf_counter()
    ray.init(address="local", num_cpus=cores, include_dashboard=False, log_to_driver=False)
    figures: dict = {"machine": machine(), "load_before": load, "cores": cores,
                     "ray": ray.__version__, "ray_start_seconds": time.perf_counter() - ray_start,
                     "parts": sorted(parts)}
    on_ray = RayExecutor()
    if "empty" in parts:
        figures["empty"] = {name: empty_tasks(ex, cores, args.empty)
                            for name, ex in (("local", LOCAL), ("ray", on_ray))}
        print(json.dumps(figures, indent=1), flush=True)
    with tempfile.TemporaryDirectory(prefix="bench-ray-") as tmp:
        tmp_path = Path(tmp)
        if "build" in parts:
            build_part(figures, tmp_path, on_ray, cores, args.boards)
        if "eval" in parts:
            eval_part(figures, tmp_path, on_ray, cores, args.eval_boards)
        if parts & {"rollout", "actors"}:
            rollout_parts(figures, parts, tmp_path, on_ray, cores, args.rollout_boards)
    figures["load_after"] = os.getloadavg()
    ray.shutdown()
    table = summary_table(figures)
    figures["table"] = table
    if {"build", "eval"} <= parts:
        figures["projection"] = projection(figures)
    print(json.dumps(figures, indent=1))
    print(table)
    print(figures.get("projection", ""))
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1) + "\n")


def build_part(figures: dict, tmp_path: Path, on_ray, cores: int, boards: int) -> None:
    figures["build"] = {name: build(tmp_path / f"build-{name}", ex, cores, boards)
                        for name, ex in (("local", LOCAL), ("ray", on_ray))}
    manifests = {(tmp_path / f"build-{n}" / "manifest.json").read_bytes()
                 for n in ("local", "ray")}
    figures["build"]["same_manifest"] = len(manifests) == 1
    from pcbdata.publish import publish_set

    _, wall, cpu = timed(lambda: publish_set(tmp_path / "build-local", ["d2"]))
    figures["publish"] = {"boards": boards, "seconds": wall, "driver_cpu": cpu}
    print(json.dumps(figures, indent=1), flush=True)


def eval_part(figures: dict, tmp_path: Path, on_ray, cores: int, boards: int) -> None:
    root, runs = tmp_path / "set", tmp_path / "runs"
    build_level(root, "d2", options=SyntheticOptions(splits=["test"], count=boards, workers=cores,
                                            publish=False, log=lambda line: None))
    figures["rollouts"] = make_rollouts(root, runs, boards)
    figures["eval_boards"] = boards
    runs_eval = {"local": (LOCAL, cores), "ray": (on_ray, cores),
                 "local_8_per_core": (LOCAL, min(32, 8 * cores))}
    figures["eval"] = {name: evaluate(root, runs, tmp_path / f"report-{name}", ex, w)
                       for name, (ex, w) in runs_eval.items()}
    reports = {json.dumps({k: v.decode() for k, v in e.pop("report").items()})
               for e in figures["eval"].values()}
    figures["eval"]["same_reports"] = len(reports) == 1


def summary_table(f: dict) -> str:
    rows = ["| work | tasks | local s | Ray s | Ray overhead per task | driver CPU per task "
            "(local / Ray) |", "|---|---:|---:|---:|---:|---:|"]
    cores = f["cores"]

    def row(label: str, tasks: int, local: dict, ray: dict) -> None:
        # wall seconds lost per task and core: what one task costs a worker slot more on Ray
        over = (ray["seconds"] - local["seconds"]) * cores / tasks * 1000
        rows.append(f"| {label} | {tasks} | {local['seconds']:.1f} | {ray['seconds']:.1f} | "
                    f"{over:+.1f} ms | {local['driver_cpu'] / tasks * 1000:.2f} / "
                    f"{ray['driver_cpu'] / tasks * 1000:.2f} ms |")

    if "empty" in f:
        e = f["empty"]
        row("empty task", e["local"]["tasks"], e["local"], e["ray"])
    if "build" in f:
        b = f["build"]
        chunks = -(-b["local"]["boards"] // 128)
        row(f"D2 build, {b['local']['boards']} boards ({chunks} chunks + "
            f"{b['local']['checked']} checks)", chunks + b["local"]["checked"], b["local"],
            b["ray"])
    if "eval" in f:
        v = f["eval"]
        row(f"eval, {v['local']['rollouts']} D2 rollouts + {f['eval_boards']} bare boards",
            v["local"]["rollouts"] + f["eval_boards"], v["local"], v["ray"])
        row(f"eval, the same, local at {min(32, 8 * cores)} workers",
            v["local"]["rollouts"] + f["eval_boards"], v["local_8_per_core"], v["ray"])
    if "rollout" in f:
        r = f["rollout"]
        row(f"rollout, {r['local']['rollouts']} scripted D2 episodes", r["local"]["rollouts"],
            r["local"], r["ray"])
    if "actors" in f:  # one local env in turn against one actor per CPU: per step, not task
        a = f["actors"]
        local, ray = a["local_one_env"], a["ray_actors"]
        over = (ray["seconds"] * a["actors"] - local["seconds"]) / a["steps"] * 1000
        rows.append(f"| {a['episodes']} scripted D2 episodes, {a['steps']} steps: 1 local env "
                    f"/ {a['actors']} actors (per step) | {a['steps']} | "
                    f"{local['seconds']:.1f} | {ray['seconds']:.1f} | {over:+.1f} ms | "
                    f"{local['driver_cpu'] / a['steps'] * 1000:.2f} / "
                    f"{ray['driver_cpu'] / a['steps'] * 1000:.2f} ms |")
    return "\n".join(rows)


def projection(f: dict, rollouts: int = 100_000, k: int = 5, boards: int = 1_000_000) -> str:
    """Time on paper on 10, 100 and 1000 cores from the measured per-task costs: the workers'
    share (local core-seconds per task plus Ray's extra per task) divided by the cores, or the
    driver's CPU per task times the tasks if that is longer (one driver process), plus the
    driver's serial publication of a build."""
    cores = f["cores"]
    ev, bd = f["eval"], f["build"]
    eval_tasks = ev["local"]["rollouts"] + f["eval_boards"]
    per_rollout = ev["local"]["seconds"] * cores / eval_tasks
    ray_extra = max(0.0, (ev["ray"]["seconds"] - ev["local"]["seconds"]) * cores / eval_tasks)
    driver_rollout = ev["ray"]["driver_cpu"] / eval_tasks
    per_board = bd["local"]["seconds"] * cores / bd["local"]["boards"]
    ray_extra_board = max(0.0, (bd["ray"]["seconds"] - bd["local"]["seconds"]) * cores
                          / bd["local"]["boards"])
    driver_board = bd["ray"]["driver_cpu"] / bd["local"]["boards"]
    publish_board = f["publish"]["seconds"] / f["publish"]["boards"]
    tasks = rollouts + rollouts // k
    lines = [f"per task, measured: scoring {per_rollout * 1000:.1f} ms of a core "
             f"(+{ray_extra * 1000:.1f} ms on Ray), driver {driver_rollout * 1000:.2f} ms; "
             f"D2 board {per_board * 1000:.2f} ms of a core (+{ray_extra_board * 1000:.2f} ms "
             f"on Ray), driver {driver_board * 1000:.3f} ms + publication "
             f"{publish_board * 1000:.2f} ms",
             "",
             f"| cores | {rollouts} rollouts ({tasks} tasks) | {boards} D2 boards: build | "
             f"+ publication (driver) |", "|---:|---:|---:|---:|"]
    for n in (10, 100, 1000):
        workers = tasks * (per_rollout + ray_extra) / n
        driver = tasks * driver_rollout
        e = max(workers, driver)
        b = max(boards * (per_board + ray_extra_board) / n, boards * driver_board)
        lines.append(f"| {n} | {e:.0f} s{' (driver-bound)' if driver > workers else ''} | "
                     f"{b:.0f} s{' (driver-bound)' if boards * driver_board > b - 1e-9 else ''}"
                     f" | +{boards * publish_board:.0f} s |")
    lines.append("")
    lines.append(f"driver-bound beyond about {(per_rollout + ray_extra) / driver_rollout:.0f} "
                 f"cores for eval and {(per_board + ray_extra_board) / driver_board:.0f} cores "
                 f"for a build (before its publication)")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
