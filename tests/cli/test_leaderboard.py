"""`pcbdata leaderboard`: grouping by set fingerprint, --rescore, every bad input refused with
one line and nothing written, and the site in headless Chromium (rows after the script ran,
a row's link to its board page with the picture and the DRC list)."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from pcbdata.cli import main
from pcbdata.core.tree import REFERENCE_FILE
from pcbdata.evaluator.results import derive
from pcbdata.testing.sets import seal_set
from tests.evaluator.boards import ROUTE_A, ROUTE_B, base_board, routed, write_board, write_instance


def make_set(root: Path, boards: tuple[str, ...]) -> Path:
    for board_id in boards:
        write_instance(base_board(), root / "d2" / "test" / board_id)
    write_instance(base_board(), root / "d2" / "train" / "t0")
    write_board(routed(base_board(), [ROUTE_A, ROUTE_B]),
                root / "d2" / "test" / boards[0] / REFERENCE_FILE)
    return seal_set(root)


def make_runs(folder: Path, boards: dict) -> Path:
    for board_id, (tracks, seconds) in boards.items():
        write_board(routed(base_board(), tracks), folder / board_id / "0.kicad_pcb")
        (folder / board_id / "0.json").write_text(json.dumps({
            "time_s": seconds, "agent": "scripted", "env_id": "pcbdata/Route-d2-v2",
            "seed": 0}))
    return folder


def evaluate(board_set: Path, runs: Path, out: Path) -> Path:
    assert main(["eval", str(board_set), "--config", "d2", "--runs", str(runs), "--out",
                 str(out), "--k", "1", "--workers", "2"]) == 0
    return out / "results.json"


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Two submissions on one set (clean, half routed) and one on a set of three boards."""
    base = tmp_path_factory.mktemp("lb")
    one = make_set(base / "set", ("b0", "b1"))
    other = make_set(base / "set3", ("b0", "b1", "b2"))
    clean = {b: ([ROUTE_A, ROUTE_B], 1.0 + i) for i, b in enumerate(("b0", "b1", "b2"))}
    half = {"b0": ([ROUTE_A], 3.0), "b1": ([ROUTE_A, ROUTE_B], 5.0)}
    return {"clean": evaluate(one, make_runs(base / "runs" / "clean", dict(
                list(clean.items())[:2])), base / "r-clean"),
            "half": evaluate(one, make_runs(base / "runs" / "half", half), base / "r-half"),
            "other": evaluate(other, make_runs(base / "runs" / "other", clean), base / "r-3"),
            "set": one, "base": base}


def run(*argv: str) -> int:
    return main(["leaderboard", *argv, "--workers", "2"])


def edited(source: Path, target: Path, change) -> Path:
    data = json.loads(source.read_text())
    change(data)
    target.write_text(json.dumps(data))
    return target


def test_files_of_different_sets_are_kept_apart_with_the_reason(results, tmp_path, capsys):
    out = tmp_path / "site"
    assert run(str(results["clean"]), str(results["half"]), str(results["other"]),
               "--out", str(out), "--no-pictures") == 0
    printed = capsys.readouterr().out
    assert "kept apart from table" in printed and "manifest_sha256" in printed
    text = (out / "leaderboard.md").read_text()
    tables = text.split("## Table ")[1:]
    assert len(tables) == 2
    together = next(t for t in tables if "| clean (@1) |" in t)
    assert "| half (@1) |" in together and "| other (@1) |" not in together
    assert together.index("| clean (@1) |") < together.index("| half (@1) |")  # CP first
    assert "| clean (@1) | 100.0 | " in together and "| 1.50 (1.50) |" in together
    assert all("manifest_sha256" in t and "differ" in t for t in tables)


def test_rescore_accepts_the_file_and_refuses_one_figure_edited(results, tmp_path, capsys):
    assert run(str(results["clean"]), str(results["half"]), "--rescore", "--out",
               str(tmp_path / "ok"), "--no-pictures") == 0
    assert capsys.readouterr().out.count("rescored, its figures hold") == 2

    def shorter(data):  # one rollout's WL, with its board and aggregates made to agree
        data["boards"][0]["rollouts"][0]["wl"] -= 1.0
        data.update(derive(data))

    forged = edited(results["clean"], tmp_path / "forged.json", shorter)
    assert run(str(forged), "--out", str(tmp_path / "plain"), "--no-pictures") == 0
    capsys.readouterr()
    out = tmp_path / "site"
    assert run(str(forged), "--rescore", "--out", str(out), "--no-pictures") == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"pcbdata: error: {forged}: its figures are not what its boards give when "
                   f"rescored (boards[b0].rollouts[0].wl is 79.0, 80.0 expected)")
    assert not out.exists()


def _bad_inputs(results, tmp: Path) -> list[tuple[list[str], str]]:
    clean = results["clean"]
    runs = json.loads(clean.read_text())["runs"]
    lacking = tmp / "lacking"
    shutil.copytree(runs, lacking)
    shutil.rmtree(lacking / "b1")
    (tmp / "cut.json").write_text(clean.read_text()[:200])

    def at_k(data):
        data["aggregates"]["at_k"]["pot"]["mean"] += 0.5

    def evaluator(data):
        data["evaluator_version"] = "2.0.0"

    def split(data):
        data["set"]["split"] = "train"

    def no_kicad(data):
        del data["kicad_version"]

    half = str(results["half"])  # a good file beside a bad one: still nothing is written
    return [
        ([half, str(tmp / "cut.json")], f"{tmp / 'cut.json'}: not valid JSON ("),
        ([half, str(edited(clean, tmp / "schema.json", no_kicad))],
         f"{tmp / 'schema.json'}: not a valid pcbdata-results-1 file ((top level): "
         f"'kicad_version' is a required property)"),
        ([half, str(edited(clean, tmp / "figure.json", at_k))],
         f"{tmp / 'figure.json'}: its figures are not what its own rollouts give "
         f"(aggregates.at_k.pot.mean is "),
        ([str(edited(clean, tmp / "old.json", evaluator)), "--rescore"],
         f"{tmp / 'old.json'}: scored by evaluator 2.0.0, this is "),
        ([str(clean), "--rescore", "--runs", str(lacking)],
         f"{clean}: its runs folder {lacking} lacks board b1, which the file lists"),
        ([str(edited(clean, tmp / "split.json", split)), "--rescore"],
         f"{tmp / 'split.json'}: its boards (b0, b1) are not those of d2/train in "),
    ]


def test_each_bad_input_is_one_line_naming_the_file_and_nothing_is_written(results, tmp_path,
                                                                          capsys):
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    sites = tmp_path / "sites"
    sites.mkdir()
    for argv, message in _bad_inputs(results, inputs):
        out = sites / "site"
        assert run(*argv, "--out", str(out), "--no-pictures") == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith(f"pcbdata: error: {message}"), err
        assert not out.exists() and not list(sites.iterdir()), argv


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def dump_dom(url: str, profile: Path) -> str:
    """The page's DOM after its scripts ran, from headless Chromium (offline)."""
    command = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
               "--no-first-run", "--disable-background-networking",
               "--disable-component-update", "--disable-sync", f"--user-data-dir={profile}",
               "--dump-dom", url]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)
    if done.returncode != 0 or "<html" not in done.stdout:
        pytest.skip(f"chromium cannot start here (exit {done.returncode}): "
                    f"{done.stderr.strip().splitlines()[-1:]}")
    return done.stdout


@pytest.mark.skipif(chromium() is None, reason="chromium is not installed (scripts/setup.sh "
                    "installs Debian's)")
def test_the_site_in_a_browser(results, tmp_path, capsys):
    out = tmp_path / "site"
    assert run(str(results["half"]), str(results["clean"]), "--out", str(out)) == 0
    assert "4 pictures" in capsys.readouterr().out
    dom = dump_dom((out / "index.html").as_uri(), tmp_path / "profile")
    table = re.search(r'<table class="sortable"[^>]*data-sorted="CP \(%\)"[^>]*>(.*?)</table>',
                      dom, re.S)
    assert table, "the table was not sorted by its script"
    rows = re.findall(r"<tr>(.*?)</tr>", table.group(1).split("<tbody>")[1], re.S)
    assert len(rows) == 2
    assert ">clean (@1)</a>" in rows[0] and ">half (@1)</a>" in rows[1]  # sorted by CP
    link = re.search(r'<a href="([^"]+)">clean \(@1\)</a>', rows[0]).group(1)
    page = out / link
    board = dump_dom(page.as_uri(), tmp_path / "profile")
    section = re.search(r'<section id="b0">(.*?)</section>', board, re.S).group(1)
    picture = re.search(r'<img class="board" src="([^"]+)"', section).group(1)
    assert (page.parent / picture).read_bytes().startswith(b"\x89PNG")
    assert re.search(r'<ul class="drc"><li>none</li></ul>', section)
    half = out / re.search(r'<a href="([^"]+)">half \(@1\)</a>', rows[1]).group(1)
    section = re.search(r'<section id="b0">(.*?)</section>',
                        dump_dom(half.as_uri(), tmp_path / "profile"), re.S).group(1)
    assert '<ul class="drc"><li>unconnected_items: 1</li></ul>' in section
