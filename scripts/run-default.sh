#!/usr/bin/env bash
# Set-up (if needed), then the built-in default job: the benchmark's D2 test split, checked in
# KiCad, written to build/d2-default, and verified against its manifest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
.venv/bin/pcbdata build d2 --splits test --out build/d2-default
.venv/bin/pcbdata verify build/d2-default
