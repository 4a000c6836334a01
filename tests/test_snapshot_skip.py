"""`skip_without_snapshot`: a skip on a developer's machine, a failure where the snapshot is
required (PCBDATA_REQUIRE_SNAPSHOT=1, set by `.ci/run`)."""
from __future__ import annotations

import pytest

from tests.helpers import REQUIRE_SNAPSHOT, skip_without_snapshot

WHY = "needs the PCBench snapshot at /nowhere/pcbench.tar.xz"


@pytest.mark.parametrize("value", [None, "0", ""])
def test_it_skips_with_the_message_unless_required(monkeypatch, value):
    if value is None:
        monkeypatch.delenv(REQUIRE_SNAPSHOT, raising=False)
    else:
        monkeypatch.setenv(REQUIRE_SNAPSHOT, value)
    with pytest.raises(pytest.skip.Exception, match=WHY):
        skip_without_snapshot(WHY)


def test_it_fails_with_the_message_when_required(monkeypatch):
    monkeypatch.setenv(REQUIRE_SNAPSHOT, "1")
    with pytest.raises(pytest.fail.Exception, match=WHY) as failed:
        skip_without_snapshot(WHY)
    assert REQUIRE_SNAPSHOT in str(failed.value)


def test_ci_requires_the_snapshot():
    from tests.conftest import REPO_ROOT

    lines = (REPO_ROOT / ".ci" / "run").read_text().splitlines()
    required = lines.index(f"export {REQUIRE_SNAPSHOT}=1")
    assert required < next(i for i, line in enumerate(lines) if "scripts/test.sh" in line)
