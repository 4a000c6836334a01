#!/usr/bin/env bash
# Set-up (if needed), then the linter, the type checker and the whole test suite, as CI runs
# them. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/python -m ruff check pcbdata tests examples
.venv/bin/python -m mypy pcbdata
exec .venv/bin/python -m pytest "$@"
