"""A tool-using language model routes one D2 board through `pcbdata.env.llm.wrapper`, then
`pcbdata eval` scores the saved board.

    export OPENAI_API_KEY=...                      # no key: the scripted stand-in plays
    export OPENAI_BASE_URL=https://api.openai.com/v1   # or any OpenAI-compatible server
    export PCBDATA_LLM_MODEL=gpt-4o-mini           # the model name that server knows
    python examples/llm_episode.py --out runs-llm [--board 0] [--max-steps 60]

It builds a one-board D2 test set (`pcbdata build d2 --count`), runs one episode with
`run_episode(env, model)` where `model(messages, tools)` posts to `<base>/chat/completions`
(`tools` as given, `tool_choice` auto) and hands back the assistant message (its
`tool_calls` or its text: the wrapper's parser reads either), saves the board as
`OUT/runs/<board_id>/0.kicad_pcb` and runs `pcbdata eval` on it. Standard library only (no
client package). Without `OPENAI_API_KEY` it says so and uses
`pcbdata.agents.llm_standin.ScriptedModel` (the scripted baseline speaking the same text
protocol), so the whole path runs offline.

Not a test and not run in CI. Checked here: the offline path end to end (stand-in episode,
save, `pcbdata eval`); the request body against OpenAI's chat-completions reference
(`model`, `messages`, `tools`, `tool_choice`; the reply in `choices[0].message`). No call to a
real API was made from this machine (no network).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import gymnasium as gym

import pcbdata.env  # noqa: F401 - registers the ids
from pcbdata.agents.llm_standin import ScriptedModel
from pcbdata.env.llm.wrapper import LLMWrapper, run_episode


class ChatCompletionsModel:
    """`reply = model(messages, tools)` over an OpenAI-compatible `/chat/completions`."""

    def __init__(self, base_url: str, api_key: str, model: str, timeout_s: float = 120.0):
        self.url = base_url.rstrip("/") + "/chat/completions"
        self.api_key, self.model, self.timeout_s = api_key, model, timeout_s

    def __call__(self, messages: list[dict], tools: list[dict]) -> dict:
        body = json.dumps({"model": self.model, "messages": messages, "tools": tools,
                           "tool_choice": "auto", "temperature": 0}).encode("utf-8")
        request = urllib.request.Request(self.url, data=body, method="POST", headers={
            "Content-Type": "application/json", "Authorization": f"Bearer {self.api_key}"})
        try:
            with urllib.request.urlopen(request, timeout=self.timeout_s) as response:
                answer = json.load(response)
        except urllib.error.HTTPError as exc:
            raise SystemExit(f"{self.url}: HTTP {exc.code}: {exc.read()[:300]!r}") from None
        except urllib.error.URLError as exc:
            raise SystemExit(f"{self.url}: {exc.reason}") from None
        return answer["choices"][0]["message"]  # {"content": ..., "tool_calls": [...]}


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
    args = parser.parse_args()

    board_set = build_set(args.out, args.board + 1)
    env = gym.make("pcbdata/Route-d2-v2", root=str(board_set), split="test",
                   max_steps=args.max_steps, counting="evaluation")
    wrapper = LLMWrapper(env)
    key = os.environ.get("OPENAI_API_KEY")
    if key:
        model = ChatCompletionsModel(os.environ.get("OPENAI_BASE_URL", "https://api.openai.com/v1"),
                                     key, os.environ.get("PCBDATA_LLM_MODEL", "gpt-4o-mini"))
    else:
        print("OPENAI_API_KEY is not set: the scripted stand-in plays instead of a language "
              "model (set OPENAI_API_KEY, and OPENAI_BASE_URL / PCBDATA_LLM_MODEL for another "
              "server or model).", file=sys.stderr)
        model = ScriptedModel(wrapper)
    try:
        result = run_episode(wrapper, model, seed=0, options={"index": args.board})
        for record in result.records:
            print(f"step {record.step:3d}  {record.call or '<bad reply>':32s} {record.outcome}")
        print(f"{result.board_id}: reward {result.total_reward:.3f} in {result.steps} steps, "
              f"unconnected {result.unconnected}, DRV {result.drv}")
        saved = args.out / "runs" / result.board_id / "0.kicad_pcb"
        saved.parent.mkdir(parents=True, exist_ok=True)
        env.unwrapped.save(saved)  # type: ignore[attr-defined]
    finally:
        env.close()
    subprocess.run([sys.executable, "-m", "pcbdata", "eval", str(board_set), "--config", "d2",
                    "--split", "test", "--runs", str(args.out / "runs"), "--k", "1",
                    "--limit", str(args.board + 1), "--out", str(args.out / "report")],
                   check=True)


if __name__ == "__main__":
    main()
