#!/usr/bin/env bash
# Everything a fresh machine needs: KiCad 9.0.8 (bookworm-backports), a venv made from the
# system Python (which is the one that can import pcbnew), the package with its test extras,
# the DRC-wait preload (build/fastwait/) and Debian's chromium (the leaderboard's browser test).
# Idempotent: a second run only checks.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-kicad.sh

if ! /usr/bin/python3 -c "import ensurepip" 2>/dev/null; then
    sudo_cmd=""; [ "$(id -u)" = 0 ] || sudo_cmd="sudo"
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq python3-venv >/dev/null
fi
# Headless Chromium for the leaderboard site's browser test (tests/cli/test_leaderboard.py).
if ! command -v chromium >/dev/null 2>&1; then
    sudo_cmd=""; [ "$(id -u)" = 0 ] || sudo_cmd="sudo"
    $sudo_cmd apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq chromium >/dev/null
fi
if [ ! -x .venv/bin/python ]; then
    /usr/bin/python3 -m venv --system-site-packages .venv
fi
.venv/bin/python -m pip install -q --disable-pip-version-check -e ".[test,route,kicad-tools,ray,train,jumanji,realism]"
# kicad-tools' optional C++ router backend: 10-100x faster than its Python one.
if ! .venv/bin/python -c "import kicad_tools.router.router_cpp" 2>/dev/null; then
    .venv/bin/kct build-native >/dev/null 2>&1 \
        || echo "warning: kicad-tools' C++ backend did not build; its Python backend is used"
fi
# The preload that removes KiCad's 250 ms DRC polling sleep (optional: skipped without gcc).
bash scripts/build-fastwait.sh
.venv/bin/python -c "import pcbnew, pcbdata; print('pcbdata', pcbdata.__version__, 'with KiCad', pcbnew.Version())"
