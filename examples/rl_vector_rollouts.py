"""Masked random rollouts through the vectorised RL wrapper, scored by `pcbdata eval`.

    python examples/rl_vector_rollouts.py [--out rl-example] [--envs 2] [--boards 8]
        [--rollouts 1] [--max-steps 60]

1. `pcbdata build d2 --splits test --count 8` writes a small D2 test split (checked by KiCad).
2. `pcbdata.env.wrappers.rl.make_vector_env` starts N environments in spawned processes (Gymnasium's
   AsyncVectorEnv, one KiCad engine each), each with its share of the boards; a masked random
   policy (`sample_action`: an allowed type, then an allowed index and mode of that type, from
   the observation's exact masks) steps them all at once. Gymnasium resets a finished
   environment on its next step, so each environment writes its own finished episodes:
   `RUNS/<board_id>/<rollout>.kicad_pcb` + `<rollout>.json`, the layout `pcbdata eval` reads
   (`runs_dir=` of `make_rl_env`, `pcbdata.env.wrappers.recorder`).
3. `pcbdata eval` scores the runs; its summary is printed.

CPU only, no RL library needed. Checked on the 2-core development machine: about a minute in
all with the defaults (see examples/README.md). A policy from a library (e.g. sb3-contrib's
MaskablePPO) replaces `sample_action` and takes `envs.call("action_masks")` or
`obs["action_mask"]` as its mask (docs/env_rl.md).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def build_split(out: Path, boards: int) -> Path:
    """A D2 test split of `boards` boards (the first ones of the benchmark's test split)."""
    root = out / "set"
    if not (root / "d2" / "test").is_dir():
        subprocess.run([sys.executable, "-m", "pcbdata", "build", "d2", "--splits", "test",
                        "--count", str(boards), "--workers", "2", "--out", str(root)],
                       check=True)
    return root


def board_ids(root: Path) -> list[str]:
    return sorted(p.name for p in (root / "d2" / "test").iterdir()
                  if (p / "board.kicad_pcb").is_file())


def run(root: Path, runs: Path, envs_n: int, rollouts: int, max_steps: int, seed: int) -> dict:
    """Steps the vectorised environments until each has finished its scheduled episodes."""
    from pcbdata.env.wrappers.rl import make_vector_env, sample_action

    ids = board_ids(root)
    envs = make_vector_env("d2", envs_n, root=str(root), split="test", boards=ids,
                           rollouts=rollouts, runs_dir=str(runs), max_steps=max_steps)
    rng = np.random.default_rng(seed)
    steps, episodes, began = 0, 0, time.perf_counter()
    try:
        obs, info = envs.reset(seed=[seed + i for i in range(envs_n)])
        while info["scheduled_left"].any():
            actions = np.stack([sample_action({k: v[i] for k, v in obs.items()}, rng)
                                for i in range(envs_n)])
            obs, _, terminated, truncated, info = envs.step(actions)
            steps += envs_n
            episodes += int((terminated | truncated).sum())
    finally:
        envs.close()
    return {"boards": len(ids), "envs": envs_n, "steps": steps, "episodes": episodes,
            "seconds": time.perf_counter() - began}


def evaluate(root: Path, runs: Path, report: Path, rollouts: int) -> dict:
    subprocess.run([sys.executable, "-m", "pcbdata", "eval", str(root), "--config", "d2",
                    "--split", "test", "--runs", str(runs), "--out", str(report),
                    "--k", str(rollouts), "--workers", "2", "--name", "masked-random"],
                   check=True)
    return json.loads((report / "summary.json").read_text())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("rl-example"),
                        help="folder for the set, the runs and the report")
    parser.add_argument("--envs", type=int, default=2, help="vectorised environments")
    parser.add_argument("--boards", type=int, default=8, help="D2 test boards")
    parser.add_argument("--rollouts", type=int, default=1, help="rollouts per board")
    parser.add_argument("--max-steps", type=int, default=60, help="steps per episode at most")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    began = time.perf_counter()
    root = build_split(args.out, args.boards)
    runs, report = args.out / f"runs-{args.seed}", args.out / f"report-{args.seed}"
    done = run(root, runs, args.envs, args.rollouts, args.max_steps, args.seed)
    print(f"{done['episodes']} episodes, {done['steps']} steps over {done['envs']} environments"
          f" in {done['seconds']:.1f} s ({done['steps'] / done['seconds']:.0f} steps/s)")
    s = evaluate(root, runs, report, args.rollouts)
    print(f"pcbdata eval: {s['n_rollouts']} rollouts on {s['n_boards']} boards: CP "
          f"{100 * s['cp']:.1f} %, Pot. {s['pot']:.2f}, DRV {s['drv']:.2f}, WL {s['wl']:.1f} mm"
          f" (table above; {report / 'summary.json'})")
    print(f"runs: {runs}, report: {report}; {time.perf_counter() - began:.0f} s in all")
    return 0


if __name__ == "__main__":  # needed: spawned workers import this module without running it
    sys.exit(main())
