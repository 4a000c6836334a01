"""The parts of the language-model agents that need no KiCad: reading a plan reply, picking
copper items out of a reply, adding them to a board's text, the client's backoff and options,
and the eval summary's accounting totals."""
from __future__ import annotations

import json

import pytest

from pcbdata.agents.llm_agents import (
    copper_items,
    is_stop,
    net_table,
    plan_calls,
    with_items,
)
from pcbdata.agents.llm_client import ChatClient, client_options
from pcbdata.core.errors import UserError
from pcbdata.evaluator.accounting import llm_totals
from pcbdata.evaluator.runs import _read_sidecar

BOARD = """(kicad_pcb
\t(version 20241229)
\t(net 0 "")
\t(net 1 "GND")
\t(footprint "R"
\t\t(pad "1" smd rect (at 0 0) (net 1 "GND"))
\t)
)
"""


def test_copper_items_keeps_balanced_items_only():
    reply = ('Sure.\n```\n(segment (start 1 2) (end 3 4) (width 0.3) (layer "F.Cu") (net 1))\n'
             '(via (at 3 4) (size 1.2) (drill 0.6) (layers "F.Cu" "B.Cu") (net 1))\n'
             '(arc (start 0 0) (mid 1 1) (end 2 0) (width 0.3) (layer "B.(Cu") (net 1))\n'
             '(footprint "X")\n(segment (start 5 5) (end 6')
    items = copper_items(reply)
    assert [i.split()[0] for i in items] == ["(segment", "(via", "(arc"]
    assert items[2].endswith('(layer "B.(Cu") (net 1))')  # a quoted parenthesis is text
    assert copper_items("no routing here") == [] and copper_items("(segmentation)") == []


def test_with_items_adds_before_the_closing_parenthesis():
    out = with_items(BOARD, ["(segment (start 1 2) (end 3 4))"])
    assert out.rstrip().endswith("\t(segment (start 1 2) (end 3 4))\n)")
    assert out.count("(") == out.count(")") and with_items(BOARD, []) == BOARD
    assert net_table(BOARD) == '(net_codes\n  (net 0 "")\n  (net 1 "GND"))'


@pytest.mark.parametrize("message,expected", [
    ({"tool_calls": [{"function": {"name": "net_end", "arguments": "{}"}},
                     {"function": {"name": "finish", "arguments": "{}"}}]},
     [{"name": "net_end", "arguments": "{}"}, {"name": "finish", "arguments": "{}"}]),
    ({"content": '```json\n[{"name": "net_end", "arguments": {}}]\n```'},
     [{"name": "net_end", "arguments": {}}]),
    ({"content": 'net_select("GND")\n\nstart_route(0)\n'}, ['net_select("GND")', "start_route(0)"]),
    ({"content": None}, []),
])
def test_plan_calls_reads_each_shape(message, expected):
    assert plan_calls(message) == expected


def test_stop_is_text_without_a_tool_call():
    assert is_stop({"content": " <stop> "}) and is_stop({"content": "`STOP`"})
    assert not is_stop({"content": "<stop>", "tool_calls": [{"function": {"name": "net_end"}}]})
    assert not is_stop({"content": "stop now"})


def test_client_backoff_doubles_honours_retry_after_and_is_capped():
    client = ChatClient({"base_url": "http://127.0.0.1:9/v1", "model": "m", "backoff_s": 0.5,
                         "backoff_cap_s": 3.0})
    assert [client._backoff(a, None) for a in range(4)] == [0.5, 1.0, 2.0, 3.0]
    assert client._backoff(0, 2.5) == 2.5 and client._backoff(0, 60.0) == 3.0
    assert client.sampling(3) == {"temperature": 0.0, "seed": 3}


@pytest.mark.parametrize("options,message", [
    ({"model": "m"}, "needs --base-url"),
    ({"base_url": "ftp://x", "model": "m"}, "not an http"),
    ({"base_url": "http://x", "model": "m", "colour": 1}, "unknown language-model option"),
    ({"base_url": "http://x", "model": "m", "max_retries": -1}, "--max-retries"),
])
def test_client_options_are_checked(options, message):
    with pytest.raises(UserError, match=message):
        client_options(options)


def test_llm_totals_sum_numbers_of_readable_sidecars(tmp_path):
    def rollout(name: str, sidecar) -> object:
        (tmp_path / f"{name}.kicad_pcb").write_text("(kicad_pcb)")
        if sidecar is not None:
            text = sidecar if isinstance(sidecar, str) else json.dumps(sidecar)
            (tmp_path / f"{name}.json").write_text(text)
        return tmp_path / f"{name}.kicad_pcb"

    boards = [rollout("0", {"llm": {"accounting": {"requests": 3, "latency_s_total": 0.25,
                                                   "ok": True, "note": "x"}}}),
              rollout("1", {"llm": {"accounting": {"requests": 2, "prompt_tokens": 7}}}),
              rollout("2", {"time_s": 1.0}), rollout("3", "{not json"), rollout("4", None)]
    assert llm_totals(boards, _read_sidecar) == {"rollouts": 2, "latency_s_total": 0.25,
                                                 "prompt_tokens": 7, "requests": 5}
    assert llm_totals(boards[2:], _read_sidecar) is None


class _Probe:
    """A server on 127.0.0.1 answering GET with `get` and POST with `post` (HTTP statuses)."""

    def __init__(self, get: int, post: int):
        import threading
        from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

        statuses = {"GET": get, "POST": post}

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def _answer(self):
                length = int(self.headers.get("Content-Length", 0))
                self.rfile.read(length)
                data = json.dumps({"error": {"message": "nope"}}).encode()
                self.send_response(statuses[self.command])
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                self.wfile.write(data)

            do_GET = do_POST = _answer

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.httpd.shutdown()
        self.httpd.server_close()


def test_preflight_falls_back_to_a_tiny_chat_and_names_a_bad_key():
    with _Probe(get=404, post=200) as server:  # no /models: one tiny chat request instead
        warning = ChatClient({"base_url": server.url, "model": "m"}).preflight()
    assert warning and "GET /models failed (HTTP 404: " in warning and "goes on" in warning
    with _Probe(get=200, post=500) as server:
        assert ChatClient({"base_url": server.url, "model": "m"}).preflight() is None
    with _Probe(get=404, post=500) as server:
        with pytest.raises(UserError, match=r"POST /chat/completions failed \(HTTP 500: "):
            ChatClient({"base_url": server.url, "model": "m"}).preflight()
    with _Probe(get=401, post=200) as server:
        with pytest.raises(UserError, match="GET /models failed .HTTP 401.*is MY_KEY the right"):
            ChatClient({"base_url": server.url, "model": "m", "api_key_env": "MY_KEY"}).preflight()
