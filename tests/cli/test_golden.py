"""Same version + parameters + seed give byte-identical boards, for every preset."""
import json

from tests.golden_boards import GOLDEN, current_hashes


def test_every_preset_reproduces_its_golden_boards():
    golden = json.loads(GOLDEN.read_text())
    current = current_hashes()
    assert sorted(current) == sorted(golden)
    for config, data in golden.items():
        changed = [path for path, sha in data["files"].items()
                   if current[config]["files"].get(path) != sha]
        assert not changed, (
            f"{config}: {len(changed)} generated files changed (first: {changed[0]}). If intended, "
            f"bump the preset version and run `python -m tests.golden_boards`.")
        assert current[config]["set_version"] == data["set_version"]
