"""A tool-using language model routes one D2 board through `pcbdata.env.llm.wrapper`, then
`pcbdata eval` scores the saved board.

    python examples/llm_episode.py --out runs-llm [--board 0] [--max-steps 60] \
        [--base-url http://127.0.0.1:8000/v1 --model Qwen/Qwen2.5-7B-Instruct]
    # OPENAI_API_KEY is sent when set (a local vLLM / llama-server / Ollama needs none)

It builds a one-board D2 test set (`pcbdata build d2 --count`) and runs one episode with
`pcbdata.agents.llm_agents.LLMAgent`, the agent of `pcbdata rollout --agent llm`: one
chat-completions request per step through `pcbdata.agents.llm_client.ChatClient` (standard
library; retries, faults and accounting as docs/env_llm.md says). It prints each step, why the
episode ended and the accounting, saves the board as `OUT/runs/<board_id>/0.kicad_pcb` and
runs `pcbdata eval` on it. Without `--base-url` (or `OPENAI_BASE_URL`) it says so and the
scripted stand-in (`pcbdata.agents.llm_standin.ScriptedModel`, the scripted baseline speaking
the same protocol) plays instead, so the whole path runs offline.

For a whole set use `pcbdata rollout SET --agent llm --base-url URL --model NAME` instead.
Not a test and not run in CI; the client is tested against a local replay server
(tests/env/test_llm_rollout.py).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym

import pcbdata.env  # noqa: F401 - registers the ids
from pcbdata.agents.llm_agents import LLMAgent
from pcbdata.agents.llm_standin import ScriptedModel
from pcbdata.core.errors import PcbdataError
from pcbdata.env.llm.wrapper import LLMWrapper, run_episode


def with_model(env, args) -> str:
    """Runs the episode with the server's model; returns the board id."""
    agent = LLMAgent(seed=0, base_url=args.base_url, model=args.model)
    agent.preflight()
    env_kwargs = {"root": str(args.set), "config": "d2", "split": "test"}
    board_id = f"board_{args.board:05d}"
    record = agent.episode(env, board_id, 0, env_kwargs)
    llm = record["llm"]
    for fault in llm["faults"]:
        print(f"step {fault['step']:3d}  {fault['kind']}: {fault['reason']}")
    print(f"{board_id}: reward {record['reward']:.3f} in {record['steps']} steps, unconnected "
          f"{record['unconnected']}, DRV {record['drv']}; ended: {llm['end']}")
    print("accounting:", llm["accounting"])
    return board_id


def with_standin(env, args) -> str:
    print("no --base-url: the scripted stand-in plays instead of a language model",
          file=sys.stderr)
    wrapper = LLMWrapper(env)
    result = run_episode(wrapper, ScriptedModel(wrapper), seed=0, options={"index": args.board})
    for record in result.records:
        print(f"step {record.step:3d}  {record.call or '<bad reply>':32s} {record.outcome}")
    print(f"{result.board_id}: reward {result.total_reward:.3f} in {result.steps} steps, "
          f"unconnected {result.unconnected}, DRV {result.drv}")
    return result.board_id


def build_set(out: Path, boards: int) -> Path:
    folder = out / "set"
    subprocess.run([sys.executable, "-m", "pcbdata", "build", "d2", "--out", str(folder),
                    "--splits", "test", "--count", str(boards), "--workers", "1"], check=True)
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs-llm"))
    parser.add_argument("--board", type=int, default=0, help="test board index")
    parser.add_argument("--max-steps", type=int, default=60)
    parser.add_argument("--base-url", default=os.environ.get("OPENAI_BASE_URL"))
    parser.add_argument("--model", default=os.environ.get("PCBDATA_LLM_MODEL", "default"))
    args = parser.parse_args()

    args.set = build_set(args.out, args.board + 1)
    env = gym.make("pcbdata/Route-d2-v2", root=str(args.set), split="test",
                   max_steps=args.max_steps, counting="evaluation")
    try:
        board_id = with_model(env, args) if args.base_url else with_standin(env, args)
    except PcbdataError as exc:  # e.g. the server is down: one line, no traceback
        env.close()
        raise SystemExit(f"llm_episode: {exc}") from None
    try:
        saved = args.out / "runs" / board_id / "0.kicad_pcb"
        saved.parent.mkdir(parents=True, exist_ok=True)
        env.unwrapped.save(saved)  # type: ignore[attr-defined]
    finally:
        env.close()
    subprocess.run([sys.executable, "-m", "pcbdata", "eval", str(args.set), "--config", "d2",
                    "--split", "test", "--runs", str(args.out / "runs"), "--k", "1",
                    "--limit", str(args.board + 1), "--out", str(args.out / "report")],
                   check=True)


if __name__ == "__main__":
    main()
