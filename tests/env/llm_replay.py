"""A small chat-completions server for the language-model agent tests: a real HTTP server on
127.0.0.1 (a thread of the test process) that answers `GET /v1/models` and
`POST /v1/chat/completions` as vLLM, llama-server and Ollama do.

The rollouts run in worker processes, so the server cannot look at their environment: it
reads what a model reads, the request. The board is the `(board "<id>")` of the prompt and
the step the `(state (step N)` of the last user message; it answers with the reply the
scripted stand-in gave at that step of that board in a recording the test made first
(`record`), the whole recorded action list for `llm-plan` (the prompt says "open loop"), the
scripted board's copper items for `llm-direct` (no tools in the request). `usage` is reported
as characters / 4 (`CHARS_PER_TOKEN`), the assumption docs/env_llm.md states.

`faults` maps (board_id, seed) to a misbehaviour: `slow` (sleeps past the client's time-out),
`500`, `garbage` (not JSON), `no_tool` (prose without a call), `context` (HTTP 400 context
length), `429_once` (a 429 on that rollout's first request, then the replay), `stop_at_3`
(the text <stop> from step 3). `models` is the status of `GET /v1/models`: 200, or 404 / 501
for a server without that route, which the client's start-up check then pings with a
one-token chat request (answered without a board, not recorded in `requests`).
"""
from __future__ import annotations

import json
import math
import re
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

CHARS_PER_TOKEN = 4
SLOW_S = 1.5  # longer than the tests' request time-out, short enough to keep them fast
MAX_BODY = 1 << 24
_BOARD = re.compile(r'\(board "([^"]+)"')
_STEP = re.compile(r"\(state \(step (\d+)\)")
STOP = {"role": "assistant", "content": "<stop>"}


def record(root: Path, board_ids: list[str], out: Path, max_steps: int = 200) -> dict:
    """Per board, the scripted stand-in's replies (`replies`: assistant messages with one tool
    call, then the text <stop> if it stopped) and the copper items of its board (`copper`),
    from episodes with the environment `pcbdata rollout` makes (same options)."""
    import gymnasium as gym

    import pcbdata.env  # noqa: F401
    from pcbdata.agents.llm_standin import ScriptedModel
    from pcbdata.env.llm.wrapper import STOP as STOP_WORD
    from pcbdata.env.llm.wrapper import LLMWrapper, run_episode

    env = gym.make("pcbdata/Route-d2-v2", config="d2", root=str(root), split="test",
                   max_steps=max_steps, drc="step")
    wrapper, out_data = LLMWrapper(env), {}
    try:
        for board_id in board_ids:
            model = ScriptedModel(wrapper, style="tool_calls")
            replies: list[dict] = []

            def recorded(messages, tools, model=model, replies=replies):
                reply = model(messages, tools)
                replies.append(STOP if reply == STOP_WORD else reply)
                return reply

            run_episode(wrapper, recorded, seed=0, options={"board_id": board_id})
            saved = out / f"{board_id}.kicad_pcb"
            env.unwrapped.save(str(saved))
            out_data[board_id] = {"replies": replies, "copper": saved.read_text("utf-8")}
    finally:
        env.close()
    return out_data


def copper_text(routed: str, bare: str) -> str:
    """The routed board's segments, arcs and vias, their net codes mapped by name to the bare
    board's (what a model would write from the prompt's net table)."""
    from pcbdata.agents.llm_agents import copper_items

    def codes(text: str) -> dict[str, str]:
        return {m.group(2): m.group(1)
                for m in re.finditer(r'^\s*\(net (\d+) "([^"]*)"\)\s*$', text, re.MULTILINE)}

    by_name, routed_codes = codes(bare), codes(routed)
    mapping = {code: by_name[name] for name, code in routed_codes.items()}
    items = [re.sub(r"\(net (\d+)\)", lambda m: f"(net {mapping[m.group(1)]})", item)
             for item in copper_items(routed)]
    return "Here is the routing:\n```\n" + "\n".join(items) + "\n```\n"


class ReplayServer:
    """`with ReplayServer(recording, bare_boards) as server:` ... `server.url`."""

    def __init__(self, recording: dict, bare: dict[str, str] | None = None,
                 faults: dict | None = None, max_requests: int = 5000, models: int = 200):
        self.recording, self.bare, self.faults = recording, bare or {}, faults or {}
        self.models = models  # the status of GET /v1/models
        self.max_requests = max_requests  # a runaway client gets 503s, never an endless loop
        self.requests: list[dict] = []
        self.lock = threading.Lock()
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), _handler(self))
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.httpd.shutdown()
        self.httpd.server_close()
        self.thread.join(timeout=10)

    # ---- answers ------------------------------------------------------------------------
    def answer(self, body: dict) -> tuple[int, dict | bytes, float]:
        """(HTTP status, JSON answer or raw bytes, seconds to wait first)."""
        messages = body["messages"]
        prompt = "\n".join(str(m.get("content") or "") for m in messages)
        found = _BOARD.search(prompt)
        if found is None:  # the start-up check's ping
            return 200, self._completion({"role": "assistant", "content": "pong"}, prompt), 0.0
        board = found.group(1)
        seed = int(body.get("seed", 0))
        with self.lock:
            seen = sum(1 for r in self.requests if (r["board"], r["seed"]) == (board, seed))
            self.requests.append({"board": board, "seed": seed, "body": body})
            if len(self.requests) > self.max_requests:
                return 503, {"error": "request budget of the test server spent"}, 0.0
        fault = self.faults.get((board, seed))
        early = self._fault(fault, seen)
        if early is not None:
            return early
        step = _STEP.findall(str(messages[-1].get("content")))
        if fault == "stop_at_3" and step and int(step[-1]) >= 3:
            return 200, self._completion(STOP, prompt), 0.0
        return 200, self._completion(self._reply(body, board, step, fault), prompt), 0.0

    def _fault(self, fault, seen: int):
        if fault == "slow":
            return 200, {"choices": []}, SLOW_S
        if fault == "500":
            return 500, {"error": {"message": "internal error"}}, 0.0
        if fault == "garbage":
            return 200, b"<html>not json", 0.0
        if fault == "context":
            return 400, {"error": {"message": "This model's maximum context length is 4096 "
                                              "tokens; your request has 9000"}}, 0.0
        if fault == "429_once" and seen == 0:
            return 429, {"error": {"message": "rate limited"}}, 0.0
        return None

    def _reply(self, body: dict, board: str, step: list[str], fault) -> dict:
        replies = self.recording[board]["replies"]
        if fault == "no_tool":
            return {"role": "assistant", "content": "I would route NET1 first, then NET2."}
        if "tools" not in body:  # llm-direct
            bare = self.bare[board]
            return {"role": "assistant",
                    "content": copper_text(self.recording[board]["copper"], bare)}
        if "open loop" in str(body["messages"][0]["content"]):  # llm-plan
            calls = [c for r in replies if "tool_calls" in r for c in r["tool_calls"]]
            return {"role": "assistant", "content": None, "tool_calls": calls}
        index = int(step[-1])
        return replies[index] if index < len(replies) else STOP

    @staticmethod
    def _completion(message: dict, prompt: str) -> dict:
        completion = len(json.dumps(message))
        usage = {"prompt_tokens": math.ceil(len(prompt) / CHARS_PER_TOKEN),
                 "completion_tokens": math.ceil(completion / CHARS_PER_TOKEN)}
        usage["total_tokens"] = usage["prompt_tokens"] + usage["completion_tokens"]
        return {"id": "replay", "object": "chat.completion", "model": "replay",
                "choices": [{"index": 0, "message": message, "finish_reason": "stop"}],
                "usage": usage}


def _handler(server: ReplayServer):
    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args):  # quiet
            pass

        def do_GET(self):
            if self.path.rstrip("/") == "/v1/models" and server.models != 200:
                self.send_error(server.models)  # as http.server answers a route it lacks
            elif self.path.rstrip("/") == "/v1/models":
                self._send(200, {"object": "list", "data": [{"id": "replay",
                                                             "object": "model"}]})
            else:
                self._send(404, {"error": "not found"})

        def do_POST(self):
            length = int(self.headers.get("Content-Length", 0))
            tokenize = getattr(server, "tokenize", None)
            if self.path == "/tokenize" and tokenize is not None and 0 < length <= MAX_BODY:
                self._send(*tokenize(json.loads(self.rfile.read(length))))
                return
            if self.path != "/v1/chat/completions" or not 0 < length <= MAX_BODY:
                self._send(404, {"error": "not found"})
                return
            status, payload, wait = server.answer(json.loads(self.rfile.read(length)))
            time.sleep(wait)
            self._send(status, payload)

        def _send(self, status: int, payload) -> None:
            data = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
            try:
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)
            except (BrokenPipeError, ConnectionResetError):
                pass  # the client gave up (its time-out): nothing to answer

    return Handler
