"""A chat-completions server replaying the paper's protocol (`--agent llm-paper`,
`llm-paper-plan`, `llm-paper-direct`) on 127.0.0.1: `tests/env/llm_replay.py`'s server with
the paper's prompts read instead of pcbdata's.

`record_paper` plays episodes in this process with the scripted stand-in speaking the paper's
protocol (`PaperScriptedModel`), with malformed or refused replies put in at given steps,
and keeps each step's reply text. The server finds the board in the prompt (`(board "<id>")`)
and the step in the last user message (`## Step N`) and answers that step's recorded reply
(`FALLBACK`, a reply without an action, after the recording's end); the plan prompt gets the
accepted bodies as one `<actions>` list, the engine-free prompt the recorded board's copper
items. A request holding only a system message (the agents' token measurement) is answered
with one token, and with `tokenize=True` the server has vLLM's `POST /tokenize` too. `usage`
is characters / 4 as in the base server.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

from tests.env.llm_replay import CHARS_PER_TOKEN, ReplayServer, copper_text

_BOARD = re.compile(r'\(board "([^"]+)"')
_STEP = re.compile(r"^## Step (\d+)$", re.MULTILINE)
FALLBACK = "<think>nothing left to do</think>"

#: One reply of every malformed or refused shape of SPEC 7.2 (by the idle kind it must give).
BAD_REPLIES = {
    "empty_reply": "",
    "missing_action": "<think>I will route N0 first.</think>",
    "empty_action": "<think>hmm</think><action>   </action>",
    "duplicate_action": "<think>two</think><action>net_end</action><action>net_end</action>",
    "missing_think": "<action>net_end</action>",
    "duplicate_think": "<think>a</think><think>b</think><action>net_end</action>",
    "unknown_verb": "<think>all at once</think><action>route_all</action>",
    "arity": "<think>short</think><action>make_line 1.000 w</action>",
    "number": "<think>comma</think><action>make_line 1,500 2.000 w</action>",
    "bad_layer": "<think>inner</think><action>start_route 1.000 2.000 3</action>",
    "bad_mode": "<think>fast</think><action>finish q</action>",
    "non_ascii": "<think>go \u2192 there</think><action>net_end</action>",
    "mask": "<think>early</think><action>make_line 10.000 10.000 w</action>",
}


def record_paper(root: Path, config: str, board_ids: list[str], out: Path,
                 bad: dict[int, str] | None = None, drc: str = "terminal",
                 turns: int = 200) -> dict:
    """Per board: `replies` (each step's reply text), `bodies` (the accepted action bodies in
    order), `reward` (the episode's summed reward, as the agent ends it), `counts` (the
    session's), `copper` (the saved board's text), `messages` (the first and a later user
    message); environments made as `pcbdata rollout` makes them."""
    import gymnasium as gym

    import pcbdata.env  # noqa: F401
    from pcbdata.agents.llm_standin import PaperScriptedModel
    from pcbdata.env.llm.paper import PaperSession
    from pcbdata.env.registry import env_id_for

    env = gym.make(env_id_for(config), config=config, root=str(root), split="test",
                   max_steps=None, drc=drc)
    data = {}
    try:
        for board_id in board_ids:
            session = PaperSession(env)
            static, first, _ = session.reset(seed=0, options={"board_id": board_id})
            model = PaperScriptedModel(session, bad=bad)
            replies, messages, total, ended = [], [first], 0.0, False
            while not ended and session.turn < turns:
                reply = model()
                if reply is None:
                    break
                replies.append(reply)
                reward, terminated, truncated, _, _ = session.step(reply)
                total, ended = total + reward, terminated or truncated
                messages.append(session.user_message())
            if not ended:
                total += session.finish_episode()[0]
            saved = out / f"{board_id}.kicad_pcb"
            env.unwrapped.save(str(saved))
            bodies = [o.body for o in session.outcomes if o.accepted]
            data[board_id] = {"replies": replies, "bodies": bodies, "reward": total,
                              "counts": dict(session.counts), "static": static,
                              "copper": saved.read_text("utf-8"), "messages": messages}
    finally:
        env.close()
    return data


class PaperReplayServer(ReplayServer):
    """`with PaperReplayServer(recording, bare) as server:` ... `server.url`; `measures`
    lists the system-only requests, `tokenized` the tokenize requests."""

    def __init__(self, recording: dict, bare: dict[str, str] | None = None,
                 tokenize: bool = False, **options):
        super().__init__(recording, bare, **options)
        self.with_tokenize = tokenize
        self.measures: list[dict] = []
        self.tokenized: list[dict] = []

    def tokenize(self, body: dict) -> tuple[int, dict]:
        if not self.with_tokenize:
            return 404, {"error": "not found"}
        self.tokenized.append(body)
        text = "\n".join(str(m.get("content") or "") for m in body.get("messages", []))
        return 200, {"count": math.ceil(len(text) / CHARS_PER_TOKEN), "max_model_len": 1 << 20}

    def answer(self, body: dict) -> tuple[int, dict | bytes, float]:
        messages = body["messages"]
        prompt = "\n".join(str(m.get("content") or "") for m in messages)
        if len(messages) == 1 and messages[0].get("role") == "system":
            with self.lock:
                self.measures.append(body)
            return 200, self._completion({"role": "assistant", "content": "ok"}, prompt), 0.0
        found = _BOARD.search(prompt)
        if found is None:  # the start-up check's ping
            return 200, self._completion({"role": "assistant", "content": "pong"}, prompt), 0.0
        board, seed = found.group(1), int(body.get("seed", 0))
        with self.lock:
            self.requests.append({"board": board, "seed": seed, "body": body})
        system = str(messages[0].get("content"))
        recorded = self.recording[board]
        if "<actions>" in system:  # plan-and-execute
            text = "<actions>\n" + "\n".join(recorded["bodies"]) + "\n</actions>"
        elif "(segment (start" in system:  # engine-free
            text = copper_text(recorded["copper"], self.bare[board])
        else:
            steps = _STEP.findall(str(messages[-1].get("content")))
            index = int(steps[-1]) - 1 if steps else 0
            replies = recorded["replies"]
            text = replies[index] if index < len(replies) else FALLBACK
        return 200, self._completion({"role": "assistant", "content": text}, prompt), 0.0
