"""The leaderboard's static site: `index.html` (one sortable table per group of comparable
results, a few lines of inline JavaScript, no external assets), `leaderboard.md`, and a page
per results file with each board's picture (its best rollout beside the bare board and the
reference, DRC errors marked) and its DRC errors listed.

Pictures are drawn as `pcbdata render` draws them (`board_render`: KiCad reads the boards in
`KicadPool` workers, `core.drawing` draws). The site is built in a temporary folder beside
OUT and moved into place whole.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from html import escape
from pathlib import Path
from urllib.parse import quote

from pcbdata.core.errors import UserError
from pcbdata.core.tree import BOARD_FILE, REFERENCE_FILE, board_dir

#: A file in OUT that marks a folder this verb wrote (and may replace).
MARKER = ".pcbdata-leaderboard"
PANEL = (480, 360)

STYLE = """body{font-family:sans-serif;margin:2em;max-width:110em}
table{border-collapse:collapse;margin:1em 0}th,td{border:1px solid #bbb;padding:.3em .6em}
td{text-align:right}td:first-child{text-align:left}th{cursor:pointer;background:#eee}
.note{color:#a33}img{max-width:100%;border:1px solid #ccc}"""
#: Sorts a table by a header's column on click (numbers by `data-v`); at load, by CP.
SCRIPT = """document.querySelectorAll("table.sortable").forEach(function (table) {
  function sortBy(col, dir) {
    var body = table.tBodies[0], rows = Array.prototype.slice.call(body.rows);
    rows.sort(function (a, b) {
      var x = a.cells[col].getAttribute("data-v"), y = b.cells[col].getAttribute("data-v");
      var nx = parseFloat(x), ny = parseFloat(y);
      if (isNaN(nx) || isNaN(ny)) { return dir * String(x).localeCompare(String(y)); }
      return dir * (nx - ny);
    });
    rows.forEach(function (row) { body.appendChild(row); });
    table.setAttribute("data-sorted", table.tHead.rows[0].cells[col].textContent);
  }
  Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th, col) {
    th.addEventListener("click", function () {
      var dir = th.getAttribute("data-dir") === "desc" ? 1 : -1;
      th.setAttribute("data-dir", dir === 1 ? "asc" : "desc");
      sortBy(col, dir);
    });
  });
  sortBy(1, -1);
});"""


NOTE = ("Figures @k (each board's kept rollout); Time over every rollout. Rows share a table "
        "only when they scored the same set with the same evaluator and environment versions.")


def table_title(number: int, table) -> str:
    f = table.fingerprint
    manifest = (f["manifest_sha256"] or "none")[:12]
    env = "none" if f["env_version"] is None else f"v{f['env_version']}"
    return (f"Table {number}: {f['config']} / {f['split']} (set {f['set_version']}, manifest "
            f"{manifest}, evaluator {f['evaluator_version']}, environment {env})")


def sorted_rows(table) -> list:
    """Best first: CP, then Pot. (@k)."""
    def key(entry) -> tuple:
        at_k = entry.data["aggregates"]["at_k"]
        return (-(at_k["cp"]["mean"] or 0), -(at_k["pot"]["mean"] or 0), entry.slug)
    return sorted(table.entries, key=key)


COLUMNS = ("Method", "CP (%)", "Pot.", "Rout.", "DRV", "WL (mm)", "Via", "Time (s) mean (median)")


def row_cells(entry) -> list[tuple[str, float | str | None]]:
    """(shown text, sort value) per column of a file's row (@k figures)."""
    data = entry.data
    at_k, time = data["aggregates"]["at_k"], data["aggregates"]["time"]

    def fig(key: str, digits: int, scale: float = 1.0) -> tuple[str, float | None]:
        value = at_k[key]["mean"]
        return ("-" if value is None else f"{scale * value:.{digits}f}"), value

    timing = ("-" if time["mean"] is None
              else f"{time['mean']:.2f} ({time['median']:.2f})", time["mean"])
    return [(f"{data['method']} (@{at_k['k']})", data["method"]), fig("cp", 1, 100.0),
            fig("pot", 2), fig("rout", 3), fig("drv", 2), fig("wl", 1), fig("via", 2), timing]


def markdown(tables: list) -> str:
    lines = ["# Leaderboard", "", NOTE, ""]
    for number, table in enumerate(tables, start=1):
        lines += [f"## {table_title(number, table)}", ""]
        lines += [f"- {note}" for note in table.notes] + ([""] if table.notes else [])
        lines += ["| " + " | ".join(COLUMNS) + " |", "|---|" + "---:|" * (len(COLUMNS) - 1)]
        for entry in sorted_rows(table):
            cells = (text.replace("|", "\\|") for text, _ in row_cells(entry))
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def check_out(out: Path) -> None:
    """OUT is a new folder, an empty one, or a site this verb wrote (it is then replaced)."""
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out}: exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / MARKER).is_file():
        raise UserError(f"--out {out}: a folder that is not empty and not a leaderboard site; "
                        f"give a new folder")


def _page(title: str, body: str) -> str:
    return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{escape(title)}</title><style>{STYLE}</style></head>\n<body>\n"
            f"<h1>{escape(title)}</h1>\n{body}\n</body></html>\n")


def index_html(tables) -> str:
    parts = [f"<p>{escape(NOTE)} Click a header to sort.</p>"]
    for number, table in enumerate(tables, start=1):
        parts.append(f"<h2>{escape(table_title(number, table))}</h2>")
        parts += [f"<p class=\"note\">{escape(note)}</p>" for note in table.notes]
        head = "".join(f"<th>{escape(c)}</th>" for c in COLUMNS)
        rows = []
        for entry in table.entries:
            cells = row_cells(entry)
            link = (f"<a href=\"files/{escape(entry.slug)}/index.html\">"
                    f"{escape(cells[0][0])}</a>")
            tds = [f"<td data-v=\"{escape(str(cells[0][1]))}\">{link}</td>"]
            tds += [f"<td data-v=\"{'' if v is None else v}\">{escape(text)}</td>"
                    for text, v in cells[1:]]
            rows.append(f"<tr>{''.join(tds)}</tr>")
        parts.append(f"<table class=\"sortable\" id=\"table-{number}\"><thead><tr>{head}"
                     f"</tr></thead>\n<tbody>\n" + "\n".join(rows) + "\n</tbody></table>")
    parts.append(f"<script>\n{SCRIPT}\n</script>")
    return _page("Leaderboard", "\n".join(parts))


def _drc_list(board: dict) -> str:
    """The DRC errors of the board's kept rollout by type (evaluation count, then what the
    strict count adds), or why it has none."""
    best = next((r for r in board["rollouts"] if r["rollout"] == board["best_rollout"]), None)
    if best is None:
        reasons = sorted({f"{r['rollout']}: {r['status']} ({r['reason']})"
                          for r in board["rollouts"]})
        items = [f"<li>no scored rollout: {escape(r)}</li>" for r in reasons]
    else:
        counted = best["drv_by_type"]
        strict = {t: n - counted.get(t, 0) for t, n in best["drv_strict_by_type"].items()
                  if n > counted.get(t, 0)}
        items = [f"<li>{escape(t)}: {n}</li>" for t, n in sorted(counted.items())]
        items += [f"<li>{escape(t)}: {n} (strict count only)</li>"
                  for t, n in sorted(strict.items())]
        items = items or ["<li>none</li>"]
    return f"<ul class=\"drc\">{''.join(items)}</ul>"


def _figures(board: dict) -> str:
    keys = ("best_rollout", "cp", "pot", "rout", "drv", "unconnected", "wl", "via", "time")
    head = "".join(f"<th>{k}</th>" for k in keys)
    cells = "".join(f"<td>{escape(_fmt(board[k]))}</td>" for k in keys)
    return f"<table><tr>{head}</tr><tr>{cells}</tr></table>"


def _fmt(value) -> str:
    if value is None:
        return "-"
    return f"{value:.3f}" if isinstance(value, float) else str(value)


def file_page(entry, pictures: dict[str, str]) -> str:
    """A results file's page: what it names, then per board its figures, picture and DRC
    errors (`pictures`: board_id -> PNG file name, or the reason there is none)."""
    data = entry.data
    facts = {key: data[key] for key in ("method", "agent", "budgets", "seeds", "env_id",
                                        "evaluator_version", "kicad_version", "pcbdata_version",
                                        "convention", "runs", "machine")}
    facts["set"] = {k: data["set"][k] for k in ("name", "config", "split", "set_version",
                                                 "manifest_sha256", "release", "folder")}
    parts = [f"<p><a href=\"../../index.html\">Leaderboard</a> | "
             f"<a href=\"{RESULTS_NAME}\">{RESULTS_NAME}</a></p>",
             f"<pre>{escape(json.dumps(facts, indent=1, sort_keys=True))}</pre>"]
    for board in data["boards"]:
        board_id = board["board_id"]
        picture = pictures.get(board_id, "pictures not drawn")
        shown = (f"<img class=\"board\" src=\"{escape(quote(picture))}\" "
                 f"alt=\"{escape(board_id)}\" "
                 f"loading=\"lazy\">" if picture.endswith(".png")
                 else f"<p class=\"note\">No picture: {escape(picture)}</p>")
        parts.append(f"<section id=\"{escape(board_id)}\"><h2>{escape(board_id)}</h2>"
                     f"{_figures(board)}{shown}<h3>DRC errors (kept rollout)</h3>"
                     f"{_drc_list(board)}</section>")
    return _page(f"{data['method']} on {data['set']['config']} / {data['set']['split']}",
                 "\n".join(parts))


RESULTS_NAME = "results.json"


def _panels(entry, board: dict) -> list[tuple[str, Path]] | str:
    """(title, board file) of a board's picture: its kept rollout, the bare board, the
    reference; or why it cannot be drawn."""
    data = entry.data
    folder = board_dir(data["set"]["folder"], data["set"]["config"], data["set"]["split"],
                       board["board_id"])
    if not (folder / BOARD_FILE).is_file():
        return f"the set's board {folder / BOARD_FILE} is not on this machine"
    best = board["best_rollout"]
    panels: list[tuple[str, Path]] = []
    if best is not None and not data["reference"]:
        routed = Path(data["runs"]) / board["board_id"] / f"{best}.kicad_pcb"
        if not routed.is_file():
            return f"the rollout {routed} is not on this machine"
        panels.append((f"rollout {best}", routed))
    panels.append(("bare board", folder / BOARD_FILE))
    if (folder / REFERENCE_FILE).is_file():
        panels.append(("reference", folder / REFERENCE_FILE))
    return panels


def draw_pictures(entry, folder: Path, workers: int, log: Callable[[str], None]) -> dict:
    """Draws a file's board pictures into `folder`; board_id -> PNG name or the reason."""
    from pcbdata.board_render import Picture, draw_picture, iter_records
    from pcbdata.core.drawing import png_bytes
    from pcbdata.kicad import KicadPool

    result: dict[str, str] = {}
    pictures = []
    for board in entry.data["boards"]:
        panels = _panels(entry, board)
        if isinstance(panels, str):
            result[board["board_id"]] = panels
        else:
            pictures.append(Picture(board["board_id"], panels))
    paths = sorted({path for picture in pictures for _, path in picture.panels})
    if not paths:
        return result
    data = entry.data
    instances = board_dir(data["set"]["folder"], data["set"]["config"], data["set"]["split"],
                          "x").parent
    with KicadPool(workers=max(1, min(workers, len(paths)))) as pool:
        records = dict(iter_records(paths, pool, drc=True, instances=instances))
    for picture in pictures:
        drawn = draw_picture(picture, records, PANEL)
        if isinstance(drawn, str):
            result[picture.name] = drawn
            log(f"leaderboard: {entry.path}: {picture.name}: not drawn ({drawn})")
            continue
        name = f"{picture.name}.png"
        (folder / name).write_bytes(png_bytes(drawn))
        result[picture.name] = name
    return result


def write_site(out: Path, tables, entries, pictures: bool, workers: int,
               log: Callable[[str], None]) -> int:
    """Builds the site in a temporary folder beside `out`, then puts it in `out`'s place;
    returns the number of pictures drawn."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    drawn = 0
    try:
        for entry in entries:
            folder = tmp / "files" / entry.slug
            folder.mkdir(parents=True)
            shutil.copyfile(entry.path, folder / RESULTS_NAME)
            shown = draw_pictures(entry, folder, workers, log) if pictures else {}
            drawn += sum(name.endswith(".png") for name in shown.values())
            (folder / "index.html").write_text(file_page(entry, shown), encoding="utf-8")
        (tmp / "index.html").write_text(index_html(tables), encoding="utf-8")
        (tmp / "leaderboard.md").write_text(markdown(tables), encoding="utf-8")
        (tmp / MARKER).write_text("written by pcbdata leaderboard; replaced by the next run\n")
        os.chmod(tmp, 0o755)
        _replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return drawn


def _replace(new: Path, out: Path) -> None:
    """Moves `new` to `out`; an old site there is moved aside first and then removed."""
    if not out.exists():
        os.replace(new, out)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old.tmp", dir=out.parent))
    os.replace(out, old / "site")
    os.replace(new, out)
    shutil.rmtree(old, ignore_errors=True)
