"""`pcbdata train`: behaviour cloning from the scripted agent (or a given checkpoint), then PPO
or GRPO (`pcbdata.learn.grpo`) on the environment's Phi reward, dense or terminal, with or
without `finish`, at given weights; validation on another split picking the checkpoint
(docs/learn.md).

A run folder holds `settings.json` (all settings and the seed), `state.pt` (weights, optimiser,
counters, log: written after every phase step, so a killed run resumes where it stopped),
`log.jsonl`, `checkpoints/update_NNNNN.pt` (every `checkpoint_every` updates), `best.pt` (the
best validation so far), `curve.png`. Each PPO update resets its environments with seeds made of
(seed, update) and reseeds torch with them, so a resumed run plays the same updates as one
that was never stopped.
"""
from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
import torch

from pcbdata.agents.scripted import ScriptedAgent, ShovingScriptedAgent
from pcbdata.core.errors import UserError
from pcbdata.env.types import FINISH
from pcbdata.env.wrappers import features
from pcbdata.env.wrappers.rl import CANDIDATE_INDEXED, MODED, NET_INDEXED, make_rl_env
from pcbdata.learn import batch as batching
from pcbdata.learn import grpo
from pcbdata.learn.checkpoint import load_policy, save_policy
from pcbdata.learn.curve import draw_curve
from pcbdata.learn.derived import EpisodeReader
from pcbdata.learn.policy import SetPolicy, device, to_tensors
from pcbdata.learn.teacher import WithoutFinish

#: The agents cloning may imitate (`--teacher`).
TEACHERS = {"scripted": ScriptedAgent, "scripted-shove": ShovingScriptedAgent}
#: The learning algorithms after cloning (`--algo`) and the rewards (`--reward`, the
#: environment's option of that name).
ALGOS = ("ppo", "grpo")
REWARDS = ("dense", "terminal")


@dataclass(frozen=True)
class Settings:
    """Everything a run depends on (recorded in settings.json; a resume must match). The
    defaults are the shipped checkpoint's run (its model card)."""

    config: str = "d2"
    seed: int = 0
    dim: int = 64
    max_steps: int = 60
    drc: str = "terminal"
    teacher: str = "scripted-shove"  # the agent cloned: scripted or scripted-shove
    bc_boards: int = 512  # train boards the teacher plays for cloning
    bc_epochs: int = 20
    train_boards: int = 4096  # train boards PPO draws from
    updates: int = 200
    envs: int = 2
    rollout_steps: int = 128  # per environment and update
    ppo_epochs: int = 3
    minibatch: int = 64
    lr_bc: float = 1e-3
    lr_ppo: float = 3e-5  # small: PPO starts from the cloned policy and must not undo it
    gamma: float = 0.99
    lam: float = 0.95
    clip: float = 0.2
    entropy: float = 0.005
    val_boards: int = 32  # validation boards, greedy
    val_every: int = 10
    checkpoint_every: int = 20
    sampling_temperature: float = 8.0  # of the checkpoints' @k sampling (pcbdata.learn.agent)
    algo: str = "ppo"  # ppo or grpo (pcbdata.learn.grpo)
    reward: str = "dense"  # dense: Phi(s_t+1) - Phi(s_t) per step; terminal: Phi(s_T) - Phi(s_0)
    no_finish: bool = False  # finish masked out: environment option finish=False everywhere
    lw: float = 0.002  # lambda_w of Phi, per mm of track
    lv: float = 0.1  # lambda_v of Phi, per via
    group: int = 16  # GRPO: episodes of one board per group
    groups: int = 1  # GRPO: groups per update
    init: str = ""  # a checkpoint to start from instead of cloning ("": clone)
    minutes: float = 0.0  # > 0: the RL phase ends with the update after which another would not fit
    value_warmup: int = 0  # PPO: the first N updates train only the value head (policy frozen)

    def __post_init__(self) -> None:
        """Refused before a run folder is made, so bad settings leave nothing behind."""
        if self.teacher not in TEACHERS:
            raise UserError(f"--teacher {self.teacher}: one of {', '.join(TEACHERS)}")
        for name, allowed in (("algo", ALGOS), ("reward", REWARDS)):
            if getattr(self, name) not in allowed:
                raise UserError(f"--{name} {getattr(self, name)}: one of {', '.join(allowed)}")
        if self.lw < 0 or self.lv < 0:
            raise UserError(f"--lw {self.lw}, --lv {self.lv}: reward weights must be >= 0")
        if self.group < 2 or self.groups < 1:
            raise UserError(f"--group {self.group}, --groups {self.groups}: a group needs at "
                            "least 2 episodes, an update at least 1 group")
        if self.init and not Path(self.init).is_file():
            raise UserError(f"--init {self.init}: no such checkpoint")
        if not self.sampling_temperature > 0:
            raise UserError(f"--sampling-temperature {self.sampling_temperature}: must be > 0")


def env_options(s: Settings, split: str, count: int) -> dict:
    return {"split": split, "count": count, "max_steps": s.max_steps, "drc": s.drc,
            "reward": s.reward, "finish": not s.no_finish,
            "weights": {"lw": s.lw, "lv": s.lv}}


def variant(s: Settings) -> dict:
    """What distinguishes the run's recipe (recorded in checkpoints and on the curve)."""
    return {"algo": s.algo, "reward": s.reward, "no_finish": s.no_finish, "lw": s.lw,
            "lv": s.lv, **({"group": s.group, "groups": s.groups} if s.algo == "grpo" else {})}


def variant_label(s: Settings) -> str:
    return (f"{s.algo}, {s.reward}{', no finish' if s.no_finish else ''}, "
            f"lw {s.lw:g}, lv {s.lv:g}")


def triple_of(act: dict) -> np.ndarray:
    """The (type, index, mode) of an environment Dict action."""
    kind = int(act["type"])
    index = (int(act["net"]) if kind in NET_INDEXED else
             int(act["candidate"]) if kind in CANDIDATE_INDEXED else 0)
    return np.asarray([kind, index, int(act["mode"]) if kind in MODED else 0], dtype=np.int64)


def allowed(wrapped: dict, t: np.ndarray) -> bool:
    return bool(wrapped["index_mask"][t[0], t[1]] and wrapped["mode_mask"][t[0], t[2]])


def scripted_demos(s: Settings, log: Callable[[str], None]) -> list[tuple[dict, np.ndarray]]:
    """(compact observation, triple) of the teacher agent on `bc_boards` train boards; the
    reader's memory follows every action the teacher takes."""
    env = make_rl_env(s.config, **env_options(s, "train", s.bc_boards))
    raw_env = env.unwrapped
    layout = features.Layout.from_options(raw_env.options)  # type: ignore[attr-defined]
    demos, reader = [], EpisodeReader()
    try:
        for i in range(s.bc_boards):
            raw, info = raw_env.reset(seed=s.seed, options={"index": i})
            static = features.static_rows(raw, layout)
            agent, done = TEACHERS[s.teacher](seed=0), False
            if s.no_finish:
                agent = WithoutFinish(agent)
            reader.reset()
            while not done:
                act = agent.act(raw, info)
                if getattr(agent, "done", False):
                    break
                wrapped = batching.wrapped_observation(raw, info["action_mask"], layout, static)
                extra, t = reader.read(wrapped), triple_of(act)
                assert not (s.no_finish and t[0] == FINISH), "the teacher sent finish"
                if allowed(wrapped, t):
                    demos.append((batching.compact(wrapped, extra), t))
                reader.acted(t)
                raw, _, term, trunc, info = raw_env.step(act)
                done = term or trunc
            log(f"bc: board {i + 1}/{s.bc_boards}, {len(demos)} demonstrated steps")
    finally:
        env.close()
    return demos


def _minibatches(n: int, size: int, rng: np.random.Generator):
    order = rng.permutation(n)
    return [order[i:i + size] for i in range(0, n, size)]


def clone(policy: SetPolicy, demos, s: Settings, dev, log) -> list[float]:
    """Behaviour cloning: maximises the log-probability of the scripted actions."""
    opt = torch.optim.Adam(policy.parameters(), lr=s.lr_bc)
    rng = np.random.default_rng(s.seed)
    losses = []
    for epoch in range(s.bc_epochs):
        total = 0.0
        for idx in _minibatches(len(demos), s.minibatch, rng):
            items = batching.collate([demos[i][0] for i in idx])
            acts = torch.as_tensor(np.stack([demos[i][1] for i in idx]), device=dev)
            logp, _, _ = policy.evaluate(to_tensors(items, dev), acts)
            loss = -logp.mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(idx)
        losses.append(total / max(1, len(demos)))
        log(f"bc: epoch {epoch + 1}/{s.bc_epochs}, loss {losses[-1]:.4f}")
    return losses


def validate(policy: SetPolicy, s: Settings, dev, env=None) -> dict:
    """Greedy episodes on `val_boards` validation boards: mean return, CP (the share of
    boards left with nothing unconnected), mean WL (mm) and vias of the final boards."""
    own = env is None
    env = env or make_rl_env(s.config, **env_options(s, "validation", s.val_boards))
    returns, complete, wl, vias = [], 0, [], []
    try:
        for i in range(s.val_boards):
            obs, info = env.reset(seed=s.seed, options={"index": i})
            total, done, reader = 0.0, False, EpisodeReader()
            while not done:
                items = batching.collate([batching.compact(obs, reader.read(obs))])
                with torch.no_grad():
                    a, _, _ = policy.act(to_tensors(items, dev), greedy=True)
                chosen = a[0].cpu().numpy().astype(np.int64)
                reader.acted(chosen)
                obs, r, term, trunc, info = env.step(chosen)
                total, done = total + float(r), term or trunc
            returns.append(total)
            complete += int(info["unconnected"] == 0)
            wl.append(float(info["wl_mm"]))
            vias.append(float(info["vias"]))
    finally:
        if own:
            env.close()
    return {"val_return": float(np.mean(returns)), "val_cp": complete / s.val_boards,
            "val_wl": float(np.mean(wl)), "val_vias": float(np.mean(vias))}


@dataclass
class Rollout:
    obs: list
    actions: list
    logp: list
    values: list
    rewards: list
    dones: list
    live: list  # False: the step Gymnasium spent on an autoreset (not a transition)


def collect(policy, envs, s: Settings, update: int, dev) -> tuple[Rollout, np.ndarray, list]:
    """`rollout_steps` steps of every environment from seeded resets; (rollout, last values,
    returns of the episodes that ended)."""
    seeds = [s.seed * 1_000_003 + update * 97 + i for i in range(s.envs)]
    obs, _ = envs.reset(seed=seeds)
    gen = torch.Generator(device=dev).manual_seed(seeds[0])
    ro = Rollout([], [], [], [], [], [], [])
    running, finished = np.zeros(s.envs), []
    resetting = np.zeros(s.envs, dtype=bool)
    readers = [EpisodeReader() for _ in range(s.envs)]
    for _ in range(s.rollout_steps):
        items = _read_all(obs, readers)
        with torch.no_grad():
            a, logp, v = policy.act(to_tensors(batching.collate(items), dev), False, gen)
        for reader, chosen in zip(readers, a.cpu().numpy(), strict=True):
            reader.acted(chosen)
        obs, r, term, trunc, _ = envs.step(a.cpu().numpy().astype(np.int64))
        for i in np.flatnonzero(resetting):  # that step was the autoreset: a new episode
            readers[i].reset()
        ro.obs.append(items)
        ro.actions.append(a.cpu())
        ro.logp.append(logp.cpu())
        ro.values.append(v.cpu())
        ro.rewards.append(np.where(resetting, 0.0, r))
        ro.dones.append(term | trunc)
        ro.live.append(~resetting)
        running += np.where(resetting, 0.0, r)
        for i in np.flatnonzero((term | trunc) & ~resetting):
            finished.append(float(running[i]))
            running[i] = 0.0
        resetting = term | trunc
    with torch.no_grad():
        _, _, last = policy.act(to_tensors(batching.collate(_read_all(obs, readers)), dev), True)
    return ro, last.cpu().numpy(), finished


def _read_all(obs: dict, readers: list[EpisodeReader]) -> list[dict]:
    """The compact observation of every vector environment, through its reader."""
    items = []
    for i, reader in enumerate(readers):
        one = {k: v[i] for k, v in obs.items()}
        items.append(batching.compact(one, reader.read(one)))
    return items


def advantages(ro: Rollout, last: np.ndarray, s: Settings) -> tuple[np.ndarray, np.ndarray]:
    """GAE over the rollout ([T, N] advantages and returns)."""
    values = torch.stack(ro.values).numpy()
    rewards, dones = np.stack(ro.rewards), np.stack(ro.dones).astype(np.float64)
    adv = np.zeros_like(values, dtype=np.float64)
    gae = np.zeros(values.shape[1])
    for t in reversed(range(len(values))):
        following = last if t == len(values) - 1 else values[t + 1]
        delta = rewards[t] + s.gamma * following * (1 - dones[t]) - values[t]
        gae = delta + s.gamma * s.lam * (1 - dones[t]) * gae
        adv[t] = gae
    return adv, adv + values


def ppo_update(policy, opt, ro: Rollout, last, s: Settings, update: int, dev) -> dict:
    """Clipped-ratio PPO over the rollout; during `value_warmup` only the value head learns
    (its loss alone, every other parameter left as it is: cloning trains no critic, and an
    untrained critic's gradients through the shared encoder can undo the cloned policy)."""
    adv, ret = advantages(ro, last, s)
    warmup = update <= s.value_warmup
    live = np.stack(ro.live).reshape(-1)
    flat_obs = [o for step in ro.obs for o in step]
    acts = torch.cat(ro.actions).reshape(-1, 3)
    old = torch.cat(ro.logp).reshape(-1)
    adv_f, ret_f = adv.reshape(-1)[live], ret.reshape(-1)[live]
    keep = np.flatnonzero(live)
    adv_f = (adv_f - adv_f.mean()) / (adv_f.std() + 1e-8)
    rng = np.random.default_rng(s.seed * 7919 + update)
    stats = []
    for _ in range(s.ppo_epochs):
        for mb in _minibatches(len(keep), s.minibatch, rng):
            rows = keep[mb]
            items = batching.collate([flat_obs[i] for i in rows])
            logp, ent, v = policy.evaluate(to_tensors(items, dev), acts[rows].to(dev))
            a = torch.as_tensor(adv_f[mb], dtype=torch.float32, device=dev)
            ratio = torch.exp(logp - old[rows].to(dev))
            pg = -torch.min(ratio * a, ratio.clamp(1 - s.clip, 1 + s.clip) * a).mean()
            vl = ((v - torch.as_tensor(ret_f[mb], dtype=torch.float32, device=dev)) ** 2).mean()
            loss = 0.5 * vl if warmup else pg + 0.5 * vl - s.entropy * ent.mean()
            _step(opt, policy, loss, only=policy.value_head if warmup else None)
            stats.append((pg.item(), vl.item(), ent.mean().item()))
    pg_m, vl_m, ent_m = np.mean(stats, axis=0) if stats else (0.0, 0.0, 0.0)
    return {"policy_loss": float(pg_m), "value_loss": float(vl_m), "entropy": float(ent_m)}


def _step(opt, policy, loss, only=None) -> None:
    """One optimiser step; with `only` (a submodule), the other parameters get no gradient,
    so Adam leaves them unchanged."""
    opt.zero_grad()
    loss.backward()
    if only is not None:
        keep = {id(p) for p in only.parameters()}
        for p in policy.parameters():
            if id(p) not in keep:
                p.grad = None
    torch.nn.utils.clip_grad_norm_(policy.parameters(), 0.5)
    opt.step()


def grpo_update(policy, opt, groups: grpo.Groups, s: Settings, update: int, dev) -> dict:
    """`ppo_epochs` epochs of minibatches of the clipped ratio with the groups' advantages."""
    rng = np.random.default_rng(s.seed * 7919 + update)
    stats = []
    for _ in range(s.ppo_epochs):
        for rows in _minibatches(len(groups.obs), s.minibatch, rng):
            items = batching.collate([groups.obs[i] for i in rows])
            adv = torch.as_tensor(groups.advantages[rows], dtype=torch.float32, device=dev)
            loss, pg, ent = grpo.loss_of(policy, to_tensors(items, dev),
                                         groups.actions[rows].to(dev),
                                         groups.logp[rows].to(dev), adv, s)
            _step(opt, policy, loss)
            stats.append((pg.item(), ent.item()))
    pg_m, ent_m = np.mean(stats, axis=0) if stats else (0.0, 0.0)
    return {"policy_loss": float(pg_m), "entropy": float(ent_m),
            "group_std": float(np.mean(groups.spreads))}


#: Settings a resumed run may change: more updates extend it; the sampling temperature is
#: only written into the checkpoints, for rollouts.
EXTENDABLE = ("updates", "sampling_temperature", "minutes")


class Run:
    """A run folder: settings, resumable state, log, checkpoints, curve."""

    def __init__(self, out: Path, s: Settings):
        self.out, self.s = out, s
        out.mkdir(parents=True, exist_ok=True)
        given = asdict(s)
        path = out / "settings.json"
        if path.is_file():  # a setting newer than the run reads as its default
            recorded = {**asdict(Settings()), **json.loads(path.read_text(encoding="utf-8"))}
            changed = sorted(k for k in given
                             if k not in EXTENDABLE and recorded.get(k) != given[k])
            if changed:
                raise UserError(f"{path}: the run was started with other settings "
                                f"({', '.join(changed)}); use another --out or the same ones")
        path.write_text(json.dumps(given, indent=1, sort_keys=True) + "\n", encoding="utf-8")

    def load(self, policy, opt_state: dict) -> dict:
        path = self.out / "state.pt"
        if not path.is_file():
            return {"phase": "bc", "update": 0, "log": [], "best": None}
        data = torch.load(path, map_location="cpu", weights_only=False)
        policy.load_state_dict(data["policy"])
        opt_state.update(data.get("optimizer") or {})
        return data["progress"]

    def save(self, policy, opt, progress: dict) -> None:
        tmp = self.out / ".state.pt.tmp"
        torch.save({"policy": policy.state_dict(),
                    "optimizer": opt.state_dict() if opt is not None else None,
                    "progress": progress}, tmp)
        os.replace(tmp, self.out / "state.pt")

    def record(self, row: dict, progress: dict) -> None:
        progress["log"].append(row)
        with open(self.out / "log.jsonl", "a", encoding="utf-8") as f:
            f.write(json.dumps(row, sort_keys=True) + "\n")
        draw_curve(progress["log"], self.out / "curve.png", variant_label(self.s))


def policy_record(s: Settings, progress: dict, extra: dict) -> dict:
    return {"settings": asdict(s), "update": progress["update"], "variant": variant(s),
            "sampling_temperature": s.sampling_temperature, **extra}


def train(out, s: Settings, log: Callable[[str], None] = print) -> dict:
    """Runs (or resumes) a training run into `out`; returns the final progress."""
    out = Path(out)
    run = Run(out, s)
    torch.manual_seed(s.seed)
    dev = device()
    policy = SetPolicy(dim=s.dim).to(dev)
    opt_state: dict = {}
    progress = run.load(policy, opt_state)
    if progress["phase"] == "bc":
        _bc_phase(run, policy, dev, progress, log)
    opt = torch.optim.Adam(policy.parameters(), lr=s.lr_ppo)
    if opt_state:
        opt.load_state_dict(opt_state)
    if progress["update"] < s.updates:
        _ppo_phase(run, policy, opt, dev, progress, log)
    return progress


def _bc_phase(run: Run, policy, dev, progress, log) -> None:
    s = run.s
    began = time.perf_counter()
    if s.init:
        _start_from(policy, Path(s.init), log)
        demos, losses = [], []
    else:
        demos = scripted_demos(s, log) if s.bc_boards else []
        losses = clone(policy, demos, s, dev, log) if demos else []
    val = validate(policy, s, dev)
    row = {"phase": "bc", "update": 0, "env_steps": 0, "demos": len(demos),
           "bc_loss": losses[-1] if losses else None, "seconds": time.perf_counter() - began,
           **val}
    progress.update(phase="ppo", best=row)
    run.record(row, progress)
    save_policy(policy, run.out / "best.pt", policy_record(s, progress, row))
    run.save(policy, None, progress)
    log(f"bc: validation return {val['val_return']:.3f}, CP {val['val_cp']:.3f}")


def _start_from(policy, path: Path, log) -> None:
    """The weights of checkpoint `path` (`--init`: a fine-tune, no cloning)."""
    start, record = load_policy(path)
    if start.dim != policy.dim:
        raise UserError(f"--init {path}: a network of width {start.dim}, the run's --dim is "
                        f"{policy.dim}")
    policy.load_state_dict(start.state_dict())
    log(f"init: the weights of {path} (update {record.get('update', '-')}), no cloning")


def _ppo_phase(run: Run, policy, opt, dev, progress, log) -> None:
    from pcbdata.env.wrappers.rl import make_vector_env

    s = run.s
    mode = "Disabled" if s.algo == "grpo" else "NextStep"  # GRPO resets to its group's board
    envs = make_vector_env(s.config, s.envs, autoreset_mode=mode,
                           **env_options(s, "train", s.train_boards))
    val_env = make_rl_env(s.config, **env_options(s, "validation", s.val_boards))
    began, longest = time.perf_counter(), 0.0
    try:
        while progress["update"] < s.updates:
            # with --minutes, the last update is the one after which another would not fit
            now = time.perf_counter()
            out_of_time = s.minutes > 0 and now - began + 2 * longest > s.minutes * 60
            _one_update(run, policy, opt, envs, val_env, dev, progress, log,
                        last=out_of_time or progress["update"] + 1 == s.updates)
            longest = max(longest, time.perf_counter() - now)
            if out_of_time and progress["update"] < s.updates:
                log(f"{s.algo}: stopped after {progress['update']} updates "
                    f"(--minutes {s.minutes:g})")
                break
    finally:
        envs.close()
        val_env.close()


def _learn(policy, opt, envs, s: Settings, update: int, dev) -> tuple[dict, float]:
    """One update's collection and learning: (log row, seconds spent collecting)."""
    began = time.perf_counter()
    if s.algo == "grpo":
        groups = grpo.collect(policy, envs, s, update, dev)
        collected = time.perf_counter() - began
        stats = grpo_update(policy, opt, groups, s, update, dev)
        steps, finished = len(groups.obs), groups.returns
    else:
        ro, last, finished = collect(policy, envs, s, update, dev)
        collected = time.perf_counter() - began
        stats = ppo_update(policy, opt, ro, last, s, update, dev)
        steps = int(np.stack(ro.live).sum())
    row = {"phase": s.algo, "update": update, "env_steps": steps,
           "return": float(np.mean(finished)) if finished else None, **stats}
    return row, collected


def _one_update(run: Run, policy, opt, envs, val_env, dev, progress, log,
                last: bool = False) -> None:
    s = run.s
    update = progress["update"] + 1
    torch.manual_seed(s.seed * 1_000_003 + update)
    began = time.perf_counter()
    row, collected = _learn(policy, opt, envs, s, update, dev)
    seconds = time.perf_counter() - began
    steps = row["env_steps"]
    row.update(steps_per_s=steps / seconds, steps_per_s_collect=steps / collected)
    if update % s.val_every == 0 or last:
        row.update(validate(policy, s, dev, val_env))
        if _better(row, progress["best"]):
            progress["best"] = row
            save_policy(policy, run.out / "best.pt", policy_record(s, progress, row))
    progress["update"] = update
    if update % s.checkpoint_every == 0 or last:
        save_policy(policy, run.out / "checkpoints" / f"update_{update:05d}.pt",
                    policy_record(s, progress, row))
    run.record(row, progress)
    run.save(policy, opt, progress)
    log(f"{s.algo}: update {update}/{s.updates}, {steps} steps, {row['steps_per_s']:.1f} steps/s "
        f"({row['steps_per_s_collect']:.1f} collecting), return "
        f"{'-' if row['return'] is None else format(row['return'], '.3f')}"
        + (f", validation return {row['val_return']:.3f}, CP {row['val_cp']:.3f}"
           if "val_cp" in row else ""))


def _better(row: dict, best: dict | None) -> bool:
    if best is None:
        return True
    return (row["val_cp"], row["val_return"]) > (best["val_cp"], best["val_return"])


def settings_from(values: dict) -> Settings:
    """Settings from given values (None: the default)."""
    names = {f.name for f in fields(Settings)}
    return Settings(**{k: v for k, v in values.items() if k in names and v is not None})
