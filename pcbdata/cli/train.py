"""`pcbdata train`: train the learned router (behaviour cloning, then PPO; docs/learn.md)."""
from __future__ import annotations

from dataclasses import fields

VERB = "train"
HELP = ("train the learned router: clone the scripted agent, then PPO or GRPO (needs the train "
        "extra)")

#: Options of the run (`pcbdata.learn.train.Settings`; defaults there), with their help.
OPTIONS = {
    "config": "board config (default: d2)", "seed": "seed of everything (default: 0)",
    "dim": "network width", "max_steps": "episode step limit",
    "drc": "KiCad DRC after every step (step) or at the end (terminal, default)",
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
    "algo": "ppo (default) or grpo: groups of --group episodes of one board, advantages "
            "normalised within the group, no critic",
    "reward": "dense (default): Phi(s_t+1) - Phi(s_t) every step; terminal: Phi(s_T) - Phi(s_0) "
              "at the end",
    "no_finish": "mask the finish action out (cloning, training, validation, the checkpoint's "
                 "rollouts)",
    "lw": "lambda_w of Phi, per mm of track (default 0.002)",
    "lv": "lambda_v of Phi, per via (default 0.1)",
    "group": "GRPO: episodes per group, one board (default 16)",
    "groups": "GRPO: groups per update (default 1)",
    "init": "start from this checkpoint instead of cloning (a fine-tune)",
    "minutes": "end the PPO/GRPO phase within this wall time (minutes): the last update is the "
               "one after which another would not fit",
    "value_warmup": "PPO: the first N updates train only the value head (default 0)",
}
TYPES = {"config": str, "drc": str, "teacher": str, "lr_bc": float, "lr_ppo": float,
         "gamma": float, "lam": float, "clip": float, "entropy": float,
         "sampling_temperature": float, "algo": str, "reward": str, "lw": float, "lv": float,
         "init": str, "minutes": float}
CHOICES = {"algo": ("ppo", "grpo"), "reward": ("dense", "terminal")}
#: Flags (no value): a given flag sets the setting True.
FLAGS = ("no_finish",)


def register(parser) -> None:
    parser.add_argument("--out", required=True, metavar="RUN",
                        help="run folder: settings, state (resumes), checkpoints, best.pt, "
                             "log.jsonl, curve.png")
    for name, text in OPTIONS.items():
        flag = "--" + name.replace("_", "-")
        if name in FLAGS:
            parser.add_argument(flag, dest=name, action="store_true", default=None, help=text)
        else:
            parser.add_argument(flag, dest=name, type=TYPES.get(name, int),
                                choices=CHOICES.get(name), help=text)
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
    print(f"done: {progress['update']} {settings.algo.upper()} updates; best validation CP "
          f"{best.get('val_cp', 0):.3f}, return {best.get('val_return', 0):.3f} "
          f"(update {best.get('update', 0)}) in {args.out}/best.pt")
    return 0
