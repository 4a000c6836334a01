"""Checks a whole D3 build of the shared PCBench snapshot against the published benchmark
(SPEC section 3): the kept set (676 boards: the 678 published less the 2 the snapshot lacks),
each tier's size, the test splits (D3-A the tier less its exclusion, D3-B and D3-C the published
picks), the boards kept with open connections of their own, the exclusion made after the picks,
and the seven missing inputs. Prints one line per fact and exits 1 if any fails; `--json`
records the outcome with the machine, the date and the build's recipe.

    pcbdata build d3 --source PCBENCH --out build/d3
    python bench/d3_published.py build/d3 --json bench/runs/d3-published.json
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
from datetime import UTC, datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

#: The published counts on the shared snapshot (SPEC section 3).
TIERS = {"d3-a": (100, 99), "d3-b": (285, 10), "d3-c": (291, 10)}
KEPT = 676
OPEN = {"RGBMatrixPanelCPLD-PhotonBackpack_RGBMatrixPanel_CPLD": 88, "Kefersender_UKW TX": 2,
        "LiPoSensor_lipo_sensor": 2, "MicroMaple_MicroMaple": 1}
EXCLUDED_AFTER_PICKS = "hackaday_esp-14_power_meter__autosave-esp-14"
LEFT_OUT_OF_D3A_TEST = "0096_karabas-nano_wifi_revA"
MISSING = 7


def facts(root: Path) -> list[tuple[str, bool, str]]:
    """(fact, holds, what was found) for every published fact."""
    from pcbdata.sets.recipe import load_recipe

    manifest = json.loads((root / "manifest.json").read_text(encoding="utf-8"))
    report = json.loads((root / "curation_report.json").read_text(encoding="utf-8"))
    fates = {b["name"]: b for b in report["boards"]}
    with open(root / "characteristics.csv", newline="", encoding="utf-8") as handle:
        table = list(csv.DictReader(handle))
    published = load_recipe().published
    out = [(f"{KEPT} boards kept", len(table) == KEPT == report["fates"]["kept"],
            f"{len(table)} in the table, {report['fates']['kept']} kept")]
    for config, (full, test) in TIERS.items():
        splits = manifest["configs"][config]["splits"]
        names = sorted(b["name"] for b in splits["test"]["boards"].values())
        got = (splits["full"]["count"], splits["test"]["count"])
        out.append((f"{config}: {full} boards, test {test}", got == (full, test), f"{got}"))
        if config in published:
            same = len(set(names) & set(published[config]))
            out.append((f"{config} test = the published picks", same == len(names) == 10
                        and manifest["configs"][config].get("published_test") is True,
                        f"{same} of 10 published"))
    a_test = manifest["configs"]["d3-a"]["splits"]["test"]["boards"]
    a_full = manifest["configs"]["d3-a"]["splits"]["full"]["boards"]
    out.append((f"{LEFT_OUT_OF_D3A_TEST} in D3-A, not in its test split",
                LEFT_OUT_OF_D3A_TEST in a_full and LEFT_OUT_OF_D3A_TEST not in a_test,
                f"full {LEFT_OUT_OF_D3A_TEST in a_full}, test {LEFT_OUT_OF_D3A_TEST in a_test}"))
    for name, count in OPEN.items():
        got = fates.get(name, {})
        out.append((f"{name} kept with {count} open connections",
                    got.get("fate") == "kept" and got.get("unconnected") == count,
                    f"{got.get('fate')} / {got.get('unconnected')}"))
    gone = fates.get(EXCLUDED_AFTER_PICKS, {})
    out.append((f"{EXCLUDED_AFTER_PICKS} excluded after the picks",
                gone.get("fate") == "excluded_by_override"
                and all(r["name"] != EXCLUDED_AFTER_PICKS for r in table),
                f"{gone.get('fate')}"))
    missing = report["fates"]["missing_input"]
    out.append((f"{MISSING} source boards reported missing", missing == MISSING, f"{missing}"))
    return out


def main() -> int:
    from _measure import machine

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("set", type=Path, help="a `pcbdata build d3` output folder")
    parser.add_argument("--json", type=Path, help="write the outcome here")
    args = parser.parse_args()
    rows = facts(args.set)
    for fact, holds, found in rows:
        print(f"{'ok  ' if holds else 'FAIL'} {fact}: {found}")
    failed = sum(not holds for _, holds, _ in rows)
    print(f"{len(rows) - failed} passed, {failed} failed")
    if args.json:
        report = json.loads((args.set / "curation_report.json").read_text(encoding="utf-8"))
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            "command": f"python bench/d3_published.py {args.set}", "machine": machine(),
            "date": datetime.now(UTC).isoformat(timespec="minutes"), "recipe": report["recipe"],
            "kicad_version": report["kicad_version"],
            "facts": [{"fact": f, "holds": h, "found": x} for f, h, x in rows]},
            indent=1) + "\n")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
