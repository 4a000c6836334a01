"""`pcbdata train`: train the learned router (behaviour cloning, then PPO; docs/learn.md)."""
from __future__ import annotations

from dataclasses import fields

VERB = "train"
HELP = "train the learned router: clone the scripted agent, then PPO (needs the train extra)"

#: Options of the run (`pcbdata.learn.train.Settings`; defaults there), with their help.
OPTIONS = {
    "config": "board config (default: d2)", "seed": "seed of everything (default: 0)",
    "dim": "network width", "max_steps": "episode step limit", "drc": "step or terminal",
    "teacher": "agent cloned: scripted-shove (default) or scripted",
    "bc_boards": "train boards the teacher plays for cloning (0: no cloning)",
    "bc_epochs": "cloning epochs", "train_boards": "train boards PPO draws from",
    "updates": "PPO updates", "envs": "vector environments (spawned processes)",
    "rollout_steps": "steps per environment and update", "ppo_epochs": "epochs per update",
    "minibatch": "minibatch size", "lr_bc": "cloning learning rate",
    "lr_ppo": "PPO learning rate", "gamma": "discount", "lam": "GAE lambda",
    "clip": "PPO ratio clip", "entropy": "entropy bonus",
    "val_boards": "validation boards (greedy)", "val_every": "validate every N updates",
    "checkpoint_every": "checkpoint every N updates",
    "sampling_temperature": "temperature of the checkpoints' sampled @k rollouts (default 8)",
}
TYPES = {"config": str, "drc": str, "teacher": str, "lr_bc": float, "lr_ppo": float,
         "gamma": float, "lam": float, "clip": float, "entropy": float,
         "sampling_temperature": float}


def register(parser) -> None:
    parser.add_argument("--out", required=True, metavar="RUN",
                        help="run folder: settings, state (resumes), checkpoints, best.pt, "
                             "log.jsonl, curve.png")
    for name, text in OPTIONS.items():
        parser.add_argument("--" + name.replace("_", "-"), dest=name,
                            type=TYPES.get(name, int), help=text)
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.core.errors import UserError

    try:
        from pcbdata.learn.train import Settings, settings_from, train
    except ImportError as exc:
        raise UserError(f"pcbdata train needs the train extra (pip install "
                        f"'pcbdata[train]'): {exc}") from None
    settings = settings_from({f.name: getattr(args, f.name, None) for f in fields(Settings)})
    progress = train(args.out, settings, log=lambda line: print(line, flush=True))
    best = progress["best"] or {}
    print(f"done: {progress['update']} PPO updates; best validation CP "
          f"{best.get('val_cp', 0):.3f}, return {best.get('val_return', 0):.3f} "
          f"(update {best.get('update', 0)}) in {args.out}/best.pt")
    return 0
