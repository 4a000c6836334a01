"""One client for the OpenAI chat-completions protocol with tools (`POST <base>/chat/completions`,
`GET <base>/models`): what vLLM, llama.cpp's `llama-server` and Ollama serve.

Standard library only (`urllib.request`): the agents send one JSON body and read one JSON
answer per request, with no streaming; a client package would add a dependency (and its own
retry policy, which must be ours: bounded and recorded) for a few lines of HTTP.

Faults are data. A transient fault (connection refused or reset, a time-out, HTTP 429 or 5xx,
an answer that is not the protocol's JSON) is retried `max_retries` times with exponential
backoff (`backoff_s * 2**attempt`, at most `backoff_cap_s`; a 429's `Retry-After` is honoured
up to the cap); when the retries run out, or at once for a context-length error or another
HTTP 4xx, `chat` raises `ServerFault` with a one-line reason, which the agents record as the
end of the episode. `Accounting` counts every request as the server reports it (no token is
counted here).
"""
from __future__ import annotations

import http.client
import json
import math
import os
import re
import socket
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

from pcbdata.core.errors import UserError

#: Options of the client and of sampling, with their defaults (plain data: they travel to the
#: rollout workers and are recorded, all but the key, in each rollout's JSON).
CLIENT_DEFAULTS: dict = {"base_url": None, "model": None, "api_key_env": "OPENAI_API_KEY",
                         "temperature": 0.0, "seed": None, "max_tokens": None,
                         "timeout_s": 120.0, "max_retries": 4, "backoff_s": 1.0,
                         "backoff_cap_s": 30.0}
_CONTEXT = re.compile(r"context[_ ]length|context size|context window|maximum context|"
                      r"too many tokens|prompt is too long|exceeds the available context",
                      re.IGNORECASE)
_SHOWN = 160  # characters of a server's error body quoted in a reason


class ServerFault(Exception):
    """A request that gave no usable answer; `kind` is one of unreachable, timeout, http,
    malformed, context_length; the message is the one-line reason."""

    def __init__(self, kind: str, reason: str):
        super().__init__(reason)
        self.kind, self.reason = kind, reason


class _Transient(ServerFault):
    """A fault worth another try (`retry_after`: the server's hint in seconds, if any)."""

    def __init__(self, kind: str, reason: str, retry_after: float | None = None):
        super().__init__(kind, reason)
        self.retry_after = retry_after


@dataclass
class Accounting:
    """What the requests of one rollout cost, as the server reported it. The numbers are
    summed by `pcbdata eval` (`summary.json`, `llm`); `latency_s` lists each request's."""

    requests: int = 0
    retries: int = 0
    prompt_tokens: int = 0
    completion_tokens: int = 0
    usage_missing: int = 0  # answers without a `usage` object
    latency_s_total: float = 0.0
    parse_failures: int = 0
    latency_s: list[float] = field(default_factory=list)

    def numbers(self) -> dict:
        data = asdict(self)
        data.pop("latency_s")
        data["latency_s_total"] = round(self.latency_s_total, 6)
        return data


def client_options(options: dict) -> dict:
    """The options with their defaults; unknown names and missing URL/model are user errors."""
    unknown = sorted(set(options) - set(CLIENT_DEFAULTS))
    if unknown:
        raise UserError(f"unknown language-model option(s): {', '.join(unknown)}")
    merged = {**CLIENT_DEFAULTS, **options}
    for name, flag in (("base_url", "--base-url"), ("model", "--model")):
        if not merged[name]:
            raise UserError(f"a language-model agent needs {flag}")
    if not str(merged["base_url"]).startswith(("http://", "https://")):
        raise UserError(f"--base-url {merged['base_url']!r}: not an http:// or https:// URL")
    if merged["max_retries"] < 0 or merged["timeout_s"] <= 0 or merged["backoff_s"] < 0:
        raise UserError("--max-retries must be >= 0, --request-timeout > 0, backoff >= 0")
    return merged


class ChatClient:
    """`chat(messages, tools)` -> the assistant message (a dict), counted in `accounting`."""

    def __init__(self, options: dict, sleep: Callable[[float], None] = time.sleep):
        self.options = client_options(options)
        self.base = str(self.options["base_url"]).rstrip("/")
        self.sleep = sleep
        self.accounting = Accounting()
        self.last_usage: dict | None = None  # the last answer's usage (None: it had none)
        self.last_finish_reason: str | None = None

    def _headers(self) -> dict:
        headers = {"Content-Type": "application/json", "Accept": "application/json"}
        key = os.environ.get(self.options["api_key_env"] or "")
        if key:
            headers["Authorization"] = f"Bearer {key}"
        return headers

    def sampling(self, seed: int) -> dict:
        """The body's sampling fields for a rollout: `seed` is the rollout's (plus the
        option's offset), so rollouts differ and a run repeats."""
        out = {"temperature": self.options["temperature"],
               "seed": int(self.options["seed"] or 0) + int(seed)}
        if self.options["max_tokens"]:
            out["max_tokens"] = int(self.options["max_tokens"])
        return out

    def preflight(self) -> str | None:
        """`GET <base>/models`: a server that is down or refuses the key fails the run at once,
        with one line. A running server that answers that route with another HTTP error (a
        404 or 501: it has no such route) is asked one tiny chat request instead: when the
        chat route answers, the run goes on and the returned warning says what failed; when
        it does not, the line names both failures. None: all is well."""
        status, reason = self._probe("GET", "/models", None)
        if status == 200:
            return None
        if status == 0 or status in (401, 403):
            raise UserError(f"--base-url {self.base}: {reason}; {self._hint(status)}")
        tiny = {"model": self.options["model"], "max_tokens": 1,
                "messages": [{"role": "user", "content": "ping"}]}
        chat, chat_reason = self._probe("POST", "/chat/completions", tiny)
        if chat == 200:
            return (f"--base-url {self.base}: {reason} from a running server; its chat route "
                    f"answers, so the run goes on")
        raise UserError(f"--base-url {self.base}: {reason} from a running server, then "
                        f"{chat_reason}; {self._hint(chat)}")

    def _hint(self, status: int) -> str:
        """What to check after a failed start-up request (HTTP status; 0: no answer)."""
        if status in (401, 403):
            return f"is {self.options['api_key_env']} the right key?"
        if status == 0:
            return "is the server running?"
        return "is --base-url the server's API root (e.g. ending in /v1)?"

    def _probe(self, method: str, path: str, body: dict | None) -> tuple[int, str]:
        """(HTTP status, 0 when no answer; the failure's one-line reason)."""
        data = None if body is None else json.dumps(body).encode("utf-8")
        request = urllib.request.Request(self.base + path, data=data, headers=self._headers(),
                                         method=method)
        try:
            with urllib.request.urlopen(request, timeout=min(10.0, self.options["timeout_s"])):
                return 200, ""
        except urllib.error.HTTPError as exc:
            shown = _body_text(exc)
            detail = f"HTTP {exc.code}: {shown}" if shown else f"HTTP {exc.code}"
            return exc.code, f"{method} {path} failed ({detail})"
        except (urllib.error.URLError, OSError, http.client.HTTPException) as exc:
            return 0, f"{method} {path} failed ({_network_reason(exc)})"

    def chat(self, messages: list[dict], tools: list[dict] | None, seed: int,
             **extra) -> dict:
        """The assistant message of one completion, retried on transient faults. `extra`
        fields are added to the body; an extra field given as None removes that field (e.g.
        `max_tokens` for a server that wants `max_completion_tokens`)."""
        body: dict = {"model": self.options["model"], "messages": messages,
                      **self.sampling(seed), **extra}
        body = {key: value for key, value in body.items() if value is not None}
        if tools:
            body.update(tools=tools, tool_choice="auto")
        data = json.dumps(body).encode("utf-8")
        attempt = 0
        while True:
            try:
                return self._once(data)
            except _Transient as fault:
                if attempt >= self.options["max_retries"]:
                    raise ServerFault(fault.kind, f"{fault.reason} (after {attempt + 1} "
                                                  f"requests)") from None
                self.sleep(self._backoff(attempt, fault.retry_after))
                attempt += 1
                self.accounting.retries += 1

    def _backoff(self, attempt: int, retry_after: float | None) -> float:
        wait = self.options["backoff_s"] * 2 ** attempt
        if retry_after is not None:
            wait = max(wait, retry_after)
        return min(wait, self.options["backoff_cap_s"])

    def _once(self, data: bytes) -> dict:
        request = urllib.request.Request(f"{self.base}/chat/completions", data=data,
                                         headers=self._headers(), method="POST")
        began = time.perf_counter()
        self.accounting.requests += 1
        try:
            try:
                with urllib.request.urlopen(request, timeout=self.options["timeout_s"]) as resp:
                    raw = resp.read()
            finally:
                took = time.perf_counter() - began
                self.accounting.latency_s.append(round(took, 6))
                self.accounting.latency_s_total += took
        except urllib.error.HTTPError as exc:
            raise _http_fault(exc) from None
        except (urllib.error.URLError, OSError, http.client.HTTPException) as exc:
            kind = "timeout" if _is_timeout(exc) else "unreachable"
            raise _Transient(kind, _network_reason(exc)) from None
        return self._message(raw)

    def _message(self, raw: bytes) -> dict:
        try:
            answer = json.loads(raw.decode("utf-8"))
            message = answer["choices"][0]["message"]
            if not isinstance(message, dict):
                raise TypeError("message is not an object")
        except (UnicodeDecodeError, ValueError, KeyError, IndexError, TypeError) as exc:
            shown = raw[:60].decode("utf-8", "replace")
            raise _Transient("malformed", f"malformed answer ({type(exc).__name__}: "
                                          f"{str(exc)[:60]}; body starts {shown!r})") from None
        usage = answer.get("usage") if isinstance(answer, dict) else None
        reason = answer["choices"][0].get("finish_reason")
        self.last_finish_reason = reason if isinstance(reason, str) else None
        if isinstance(usage, dict):
            self.last_usage = {"prompt_tokens": _count(usage.get("prompt_tokens")),
                               "completion_tokens": _count(usage.get("completion_tokens"))}
            self.accounting.prompt_tokens += self.last_usage["prompt_tokens"]
            self.accounting.completion_tokens += self.last_usage["completion_tokens"]
        else:
            self.last_usage = None
            self.accounting.usage_missing += 1
        return message

    def tokenize(self, messages: list[dict]) -> tuple[int | None, str]:
        """(token count, how it was found) of `messages` from the server's tokenize route,
        outside the API root (`<base without /v1>/tokenize`): vLLM's takes the messages and
        counts them with the chat template (`count`); llama-server's takes text (`content`,
        the messages' contents joined: no template tokens) and lists its `tokens`. (None,
        why) when the server has no such route (Ollama) or answers otherwise. Not counted in
        `accounting` (no completion)."""
        root = self.base.removesuffix("/v1")
        for body in ({"model": self.options["model"], "messages": messages,
                      "add_generation_prompt": False},
                     {"content": "\n".join(str(m.get("content") or "") for m in messages)}):
            answer = self._json_post(root + "/tokenize", body)
            if isinstance(answer, dict) and "messages" in body and _count(answer.get("count")):
                return _count(answer["count"]), "tokenize route (messages, chat template)"
            if isinstance(answer, dict) and isinstance(answer.get("tokens"), list) \
                    and "content" in body:
                return len(answer["tokens"]), "tokenize route (text, no chat template)"
        return None, f"no tokenize route at {root}/tokenize"

    def _json_post(self, url: str, body: dict):
        """The JSON answer of one POST, or None on any failure (no retry)."""
        request = urllib.request.Request(url, data=json.dumps(body).encode("utf-8"),
                                         headers=self._headers(), method="POST")
        try:
            with urllib.request.urlopen(request, timeout=min(10.0, self.options["timeout_s"])) \
                    as resp:
                return json.loads(resp.read().decode("utf-8"))
        except (urllib.error.URLError, OSError, http.client.HTTPException, ValueError):
            return None


def _count(value) -> int:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    return int(value) if ok and value >= 0 else 0


def _body_text(exc: urllib.error.HTTPError) -> str:
    try:
        text = exc.read().decode("utf-8", "replace")
    except OSError:
        text = ""
    text = " ".join(text.split())
    return text if len(text) <= _SHOWN else text[: _SHOWN - 3] + "..."


def _http_fault(exc: urllib.error.HTTPError) -> ServerFault:
    body = _body_text(exc)
    reason = f"HTTP {exc.code}: {body}" if body else f"HTTP {exc.code}"
    if exc.code == 429 or exc.code >= 500:
        return _Transient("http", reason, _retry_after(exc.headers.get("Retry-After")))
    if _CONTEXT.search(body):
        return ServerFault("context_length", f"context length exceeded ({reason})")
    return ServerFault("http", reason)


def _retry_after(value) -> float | None:
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        return None
    return seconds if math.isfinite(seconds) and seconds >= 0 else None


def _is_timeout(exc: BaseException) -> bool:
    inner = getattr(exc, "reason", exc)
    return isinstance(inner, socket.timeout | TimeoutError) or "timed out" in str(inner)


def _network_reason(exc: BaseException) -> str:
    inner = getattr(exc, "reason", exc)
    if _is_timeout(exc):
        return "timed out"
    text = getattr(inner, "strerror", None) or str(inner)
    return " ".join(str(text).split())[:_SHOWN]
