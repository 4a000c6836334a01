"""Benchmark: the Ray executor on a local Ray cluster versus the local executor (issue 13).

Same machine, same work, one run each, in this order:

1. empty tasks (`os:getpid`): the cost of one task round trip through each executor;
2. a D2 build (train split, `--boards` boards, 128 of them checked in KiCad, no publishing):
   generation chunks of 128 boards + KiCad checks; the manifests must be the same bytes;
   publishing (parquet shards, card, pictures) is timed once: it runs on the driver whatever
   the executor;
3. `pcbdata eval` of D2 rollouts (`--eval-boards` test boards x 5 rollouts with straight
   tracks: shorts, clearance violations and unconnected items); the reports must be the same.

For each: wall seconds, the driver's own CPU seconds (this process, not its workers: what a
bigger cluster would wait on) and the overhead of Ray per task. The local cluster has as many
CPUs as the machine; the local executor runs as many workers (the evaluator's own default of
8 per core is timed too).

    .venv/bin/python bench/bench_ray.py --boards 10000 --eval-boards 128 --json bench-ray.json
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

from pcbdata.builders import SyntheticOptions, build_d2  # noqa: E402
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
    summary, wall, cpu = timed(lambda: build_d2(out, options=options))
    return {"boards": boards, "checked": summary.checked, "seconds": wall, "driver_cpu": cpu}


def make_rollouts(root: Path, runs: Path, boards: int) -> int:
    from pcbdata.configs import get_config
    from pcbdata.kicad_writer import board_files
    from tests.helpers import with_straight_tracks

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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boards", type=int, default=10_000, help="D2 train boards to build")
    parser.add_argument("--eval-boards", type=int, default=128,
                        help="D2 test boards to score, 5 rollouts each")
    parser.add_argument("--empty", type=int, default=2000, help="empty tasks per executor")
    parser.add_argument("--json", help="write the figures here")
    parser.add_argument("--project", metavar="JSON",
                        help="only print the projection from figures saved by --json")
    args = parser.parse_args()
    if args.project:
        print(projection(json.loads(Path(args.project).read_text())))
        return
    import ray

    cores = os.cpu_count() or 1
    load = os.getloadavg()[0]
    ray_start = time.perf_counter()
    ray.init(address="local", num_cpus=cores, include_dashboard=False, log_to_driver=False)
    figures: dict = {"machine": machine(), "load_before": load, "cores": cores,
                     "ray": ray.__version__, "ray_start_seconds": time.perf_counter() - ray_start}
    on_ray = RayExecutor()
    figures["empty"] = {name: empty_tasks(ex, cores, args.empty)
                        for name, ex in (("local", LOCAL), ("ray", on_ray))}
    print(json.dumps(figures, indent=1), flush=True)
    with tempfile.TemporaryDirectory(prefix="bench-ray-") as tmp:
        tmp_path = Path(tmp)
        figures["build"] = {name: build(tmp_path / f"build-{name}", ex, cores, args.boards)
                            for name, ex in (("local", LOCAL), ("ray", on_ray))}
        manifests = {(tmp_path / f"build-{n}" / "manifest.json").read_bytes()
                     for n in ("local", "ray")}
        figures["build"]["same_manifest"] = len(manifests) == 1
        from pcbdata.publish import publish_set

        _, wall, cpu = timed(lambda: publish_set(tmp_path / "build-local", ["d2"]))
        figures["publish"] = {"boards": args.boards, "seconds": wall, "driver_cpu": cpu}
        print(json.dumps(figures, indent=1), flush=True)

        root, runs = tmp_path / "set", tmp_path / "runs"
        build_d2(root, options=SyntheticOptions(splits=["test"], count=args.eval_boards,
                                                workers=cores, publish=False,
                                                log=lambda line: None))
        figures["rollouts"] = make_rollouts(root, runs, args.eval_boards)
        figures["eval_boards"] = args.eval_boards
        runs_eval = {"local": (LOCAL, cores), "ray": (on_ray, cores),
                     "local_8_per_core": (LOCAL, min(32, 8 * cores))}
        figures["eval"] = {name: evaluate(root, runs, tmp_path / f"report-{name}", ex, w)
                           for name, (ex, w) in runs_eval.items()}
        reports = {json.dumps({k: v.decode() for k, v in e.pop("report").items()})
                   for e in figures["eval"].values()}
        figures["eval"]["same_reports"] = len(reports) == 1
    figures["load_after"] = os.getloadavg()[0]
    ray.shutdown()
    table = summary_table(figures)
    figures["table"] = table
    figures["projection"] = projection(figures)
    print(json.dumps(figures, indent=1))
    print(table)
    print(figures["projection"])
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=1) + "\n")


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

    e = f["empty"]
    row("empty task", e["local"]["tasks"], e["local"], e["ray"])
    b = f["build"]
    chunks = -(-b["local"]["boards"] // 128)
    row(f"D2 build, {b['local']['boards']} boards ({chunks} chunks + {b['local']['checked']} "
        f"checks)", chunks + b["local"]["checked"], b["local"], b["ray"])
    v = f["eval"]
    row(f"eval, {v['local']['rollouts']} D2 rollouts + {f['eval_boards']} bare boards",
        v["local"]["rollouts"] + f["eval_boards"], v["local"], v["ray"])
    row(f"eval, the same, local at {min(32, 8 * cores)} workers",
        v["local"]["rollouts"] + f["eval_boards"], v["local_8_per_core"], v["ray"])
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
