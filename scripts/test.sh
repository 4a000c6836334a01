#!/usr/bin/env bash
# Set-up (if needed), then the linter, the type checker and the whole test suite, as CI runs
# them. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/python -m ruff check pcbdata tests examples bench
.venv/bin/python -m mypy pcbdata
# Two pytest-xdist workers, a test file per worker at a time (module fixtures built once);
# the KiCad tests wait on worker processes much of the time. PCBDATA_TEST_WORKERS=0: serial.
exec .venv/bin/python -m pytest -n "${PCBDATA_TEST_WORKERS:-2}" --dist loadfile "$@"
