"""`pcbdata rollout --agent llm | llm-plan | llm-direct` against a real chat-completions server
on 127.0.0.1 (`tests/env/llm_replay.py`), then `pcbdata eval`.

The server replays what the scripted stand-in did on each board in a recording made first in
this process: the rollouts run in worker processes, so the server only sees the requests
(board id and step from the prompt), as a real model would. Replayed episodes must score
exactly as `pcbdata rollout --agent scripted` (same per-board Pot.); a misbehaving server gives
recorded reasons, no traceback."""
from __future__ import annotations

import csv
import json
import socket
from pathlib import Path

import pytest

from pcbdata.cli import main
from tests.env.conftest import D2_BOARDS
from tests.env.llm_replay import ReplayServer, record

BOARDS = [f"board_{i:05d}" for i in range(D2_BOARDS)]
FAST = ["--request-timeout", "0.4", "--retry-backoff", "0.01", "--retry-backoff-cap", "0.05",
        "--max-retries", "2"]


def _rollout(board_set, out, agent, *extra) -> list[str]:
    return ["rollout", str(board_set), "--config", "d2", "--split", "test", "--agent", agent,
            "--out", str(out), "--workers", "2", *extra]


def _pots(board_set, runs: Path, report: Path) -> tuple[dict, dict]:
    assert main(["eval", str(board_set), "--config", "d2", "--split", "test", "--runs",
                 str(runs), "--out", str(report), "--k", "1", "--workers", "2"]) == 0
    with open(report / "per_board.csv", encoding="utf-8") as handle:
        pots = {row["board_id"]: row["pot"] for row in csv.DictReader(handle)}
    return pots, json.loads((report / "summary.json").read_text())


@pytest.fixture(scope="module")
def recording(board_set, tmp_path_factory):
    return record(board_set, BOARDS, tmp_path_factory.mktemp("recording"))


@pytest.fixture(scope="module")
def bare(board_set):
    return {b: (board_set / "d2" / "test" / b / "board.kicad_pcb").read_text("utf-8")
            for b in BOARDS}


@pytest.fixture(scope="module")
def scripted(board_set, tmp_path_factory):
    """Per-board Pot. of the scripted agent's rollouts (the figures to match)."""
    folder = tmp_path_factory.mktemp("scripted")
    assert main(_rollout(board_set, folder / "runs", "scripted")) == 0
    pots, summary = _pots(board_set, folder / "runs", folder / "report")
    assert "llm" not in summary  # no accounting in the sidecars: no totals
    assert all(float(p) > 0 for p in pots.values())
    return pots


def test_closed_loop_replay_scores_as_scripted(board_set, recording, scripted, tmp_path,
                                               capsys, monkeypatch):
    monkeypatch.setenv("REPLAY_KEY", "sk-test-secret")
    faults = {(b, 0): "429_once" for b in BOARDS}  # each rollout's first request: a 429
    runs = tmp_path / "runs"
    argv = _rollout(board_set, runs, "llm", "--model", "replay", "--api-key-env", "REPLAY_KEY",
                    "--temperature", "0.2", *FAST)
    with ReplayServer(recording, faults=faults) as server:
        assert main([*argv, "--base-url", server.url]) == 0
        printed = capsys.readouterr().out
        assert "done: 4 rollouts run" in printed and "ended: terminated" in printed
        (runs / BOARDS[1] / "0.json").unlink()  # a killed run: resumes at the missing one
        assert main([*argv, "--base-url", server.url]) == 0
        assert "done: 1 rollouts run, 3 already done" in capsys.readouterr().out
        bodies = [r["body"] for r in server.requests]
    assert all(b["temperature"] == 0.2 and b["seed"] == 0 and b["tools"] for b in bodies)
    records = {b: json.loads((runs / b / "0.json").read_text()) for b in BOARDS}
    for board, rec in records.items():
        llm = rec["llm"]
        steps = len(recording[board]["replies"])
        assert rec["terminated"] and rec["steps"] == steps, board
        assert llm["prompt_version"] and llm["end"] == "terminated"
        assert llm["options"]["sampling"] == {"temperature": 0.2, "seed": 0, "max_tokens": 512}
        identity = rec["agent_identity"]  # what results.json reads
        assert (identity["name"], identity["model"], identity["base_url"]) == (
            "llm", "replay", server.url)
        assert identity["sampling"] == {"temperature": 0.2, "seed": 0, "max_tokens": 512}
        acc = llm["accounting"]
        retries = 0 if board == BOARDS[1] else 1  # the resumed rollout met no 429
        assert (acc["requests"], acc["retries"], acc["parse_failures"]) == (steps + retries,
                                                                            retries, 0)
        assert acc["prompt_tokens"] > 0 and acc["completion_tokens"] > 0
        assert len(llm["latency_s"]) == steps + retries and rec["time_s"] > 0
        assert "sk-test-secret" not in json.dumps(rec) and "REPLAY_KEY" not in json.dumps(rec)
    pots, summary = _pots(board_set, runs, tmp_path / "report")
    assert pots == scripted
    totals = summary["llm"]
    assert totals["rollouts"] == 4 and totals["retries"] == 3
    assert totals["requests"] == sum(r["llm"]["accounting"]["requests"] for r in records.values())
    assert totals["prompt_tokens"] == sum(r["llm"]["accounting"]["prompt_tokens"]
                                          for r in records.values())


def test_open_loop_plan_and_direct_score_as_scripted(board_set, recording, bare, scripted,
                                                     tmp_path, capsys):
    with ReplayServer(recording, bare) as server:
        for agent in ("llm-plan", "llm-direct"):
            runs = tmp_path / agent
            argv = _rollout(board_set, runs, agent, "--model", "replay", "--base-url",
                            server.url, *FAST)
            assert main(argv) == 0, capsys.readouterr()
            pots, summary = _pots(board_set, runs, tmp_path / f"{agent}-report")
            assert pots == scripted, agent
            assert summary["llm"]["requests"] == 4 and summary["llm"]["parse_failures"] == 0
            rec = json.loads((runs / BOARDS[0] / "0.json").read_text())
            assert rec["llm"]["agent"] == agent and rec["llm"]["accounting"]["requests"] == 1
    assert "tools" not in server.requests[-1]["body"]  # llm-direct asks for text


def test_a_misbehaving_server_gives_recorded_reasons(board_set, recording, tmp_path, capsys):
    faults = {(BOARDS[0], 0): "slow", (BOARDS[0], 1): "500", (BOARDS[1], 0): "garbage",
              (BOARDS[1], 1): "no_tool", (BOARDS[2], 0): "context",
              (BOARDS[2], 1): "stop_at_3"}
    runs = tmp_path / "runs"
    with ReplayServer(recording, faults=faults) as server:
        code = main(_rollout(board_set, runs, "llm", "--model", "replay", "--base-url",
                             server.url, "--limit", "3", "--rollouts", "2", "--max-steps",
                             "14", *FAST))
    captured = capsys.readouterr()
    assert code == 0 and "Traceback" not in captured.out + captured.err
    ends = {}
    for (board, seed), fault in faults.items():
        rec = json.loads((runs / board / f"{seed}.json").read_text())
        ends[fault] = rec["llm"]
        assert (runs / board / f"{seed}.kicad_pcb").is_file()
    assert ends["slow"]["end"].startswith("server fault: timed out (after 3 requests)")
    assert ends["slow"]["accounting"]["retries"] == 2
    assert ends["500"]["end"].startswith("server fault: HTTP 500")
    assert ends["500"]["faults"][0]["kind"] == "http"
    assert "malformed answer" in ends["garbage"]["end"]
    assert ends["context"]["end"].startswith("server fault: context length exceeded")
    assert ends["context"]["accounting"]["retries"] == 0
    assert ends["stop_at_3"]["end"] == "stopped by the model"
    no_tool = ends["no_tool"]
    assert no_tool["end"] == "10 unreadable replies in a row"
    assert no_tool["accounting"]["parse_failures"] == no_tool["accounting"]["requests"] == 10
    assert no_tool["faults"][0]["kind"] == "unreadable"


def test_a_server_that_is_down_fails_fast(board_set, tmp_path, capsys):
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    code = main(_rollout(board_set, tmp_path / "runs", "llm", "--model", "m", "--base-url",
                         f"http://127.0.0.1:{port}/v1"))
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "GET /models failed" in err and "is the server running?" in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("models", [404, 501])
def test_a_server_without_get_models_is_used_with_a_warning(board_set, recording, tmp_path,
                                                            capsys, models):
    """A running server whose `GET /models` answers 404 or 501 (no such route) while its chat
    route answers: the run goes on, and a warning says what failed."""
    runs = tmp_path / "runs"
    with ReplayServer(recording, models=models) as server:
        code = main(_rollout(board_set, runs, "llm", "--model", "replay", "--base-url",
                             server.url, "--limit", "1", *FAST))
        requested = len(server.requests)  # the ping is not recorded
    captured = capsys.readouterr()
    assert code == 0, captured.err
    warnings = [line for line in captured.err.splitlines() if "warning" in line]
    assert len(warnings) == 1, captured.err
    assert warnings[0].startswith(f"pcbdata: warning: --base-url {server.url}: GET /models "
                                  f"failed (HTTP {models}")
    assert warnings[0].endswith("from a running server; its chat route answers, so the run "
                                "goes on")
    record = json.loads((runs / BOARDS[0] / "0.json").read_text())
    assert record["terminated"] and requested == record["llm"]["accounting"]["requests"]


def test_a_running_server_without_the_chat_route_is_not_called_down(board_set, recording,
                                                                     tmp_path, capsys):
    """--base-url without its /v1: both start-up requests get 404 from a running server."""
    with ReplayServer(recording) as server:
        base = server.url.removesuffix("/v1")
        code = main(_rollout(board_set, tmp_path / "runs", "llm", "--model", "replay",
                             "--base-url", base))
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert (f"--base-url {base}: GET /models failed (HTTP 404: " in err
            and "from a running server, then POST /chat/completions failed (HTTP 404: " in err)
    assert "is the server running?" not in err and "e.g. ending in /v1" in err
    assert not (tmp_path / "runs").exists()


def test_llm_options_are_checked(board_set, tmp_path, capsys):
    base = _rollout(board_set, tmp_path / "runs", "llm")
    assert main(base) == 2
    assert "needs --base-url" in capsys.readouterr().err
    assert main([*base, "--base-url", "http://x/v1", "--model", "m", "--api-key-env",
                 "PCBDATA_NO_SUCH_VARIABLE"]) == 2
    assert "PCBDATA_NO_SUCH_VARIABLE" in capsys.readouterr().err
    assert main(_rollout(board_set, tmp_path / "r2", "scripted", "--model", "m")) == 2
    assert "takes no language-model options" in capsys.readouterr().err
