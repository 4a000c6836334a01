"""The README's results table and docs/sets.md's levels table are generated from the run
records under bench/results/baselines/ and the published rows of bench/published.json (`python
bench/baselines.py table --write README.md`), never typed by hand."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _baselines():
    spec = importlib.util.spec_from_file_location("baselines", ROOT / "bench" / "baselines.py")
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return module


def test_readme_table_is_the_generated_one():
    baselines = _baselines()
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert baselines.readme_table(readme) == baselines.table()


def test_levels_table_is_the_generated_one():
    baselines = _baselines()
    doc = (ROOT / "docs" / "sets.md").read_text(encoding="utf-8")
    assert baselines.readme_table(doc, baselines.LEVELS_BEGIN, baselines.LEVELS_END) == \
        baselines.levels_table()


def test_every_record_names_its_commands_machine_date_and_set():
    for path in sorted((ROOT / "bench" / "results" / "baselines").glob("*__*.json")):
        record = json.loads(path.read_text())
        assert record["commands"] and record["machine"] and record["started"], path.name
        assert record["set"]["manifest_sha256"] and record["load_before"], path.name
