#!/usr/bin/env bash
# Installs KiCad 9.0.8 from Debian's bookworm-backports suite.
# The backports entry is derived from the machine's own debian.sources (same URIs and
# Signed-By) so that no mirror host name is written into this repository.
set -euo pipefail

want_version="9.0.8"
if command -v kicad-cli >/dev/null 2>&1 && kicad-cli version 2>/dev/null | grep -q "^${want_version}"; then
    echo "kicad-cli ${want_version} already installed"
    exit 0
fi

sudo_cmd=""
[ "$(id -u)" = 0 ] || sudo_cmd="sudo"

src=/etc/apt/sources.list.d/debian.sources
dst=/etc/apt/sources.list.d/bookworm-backports.sources
if [ ! -f "$dst" ]; then
    [ -f "$src" ] || { echo "error: $src not found; cannot derive a bookworm-backports entry" >&2; exit 2; }
    # Take the stanza that carries the plain 'bookworm' suite; keep its URIs and Signed-By.
    stanza=$(awk -v RS= '/(^|\n)Suites:.*[[:space:]]bookworm([[:space:]]|$)/ {print; exit}' "$src")
    uris=$(printf '%s\n' "$stanza" | sed -n 's/^URIs:[[:space:]]*//p')
    signed=$(printf '%s\n' "$stanza" | sed -n 's/^Signed-By:[[:space:]]*//p')
    [ -n "$uris" ] || { echo "error: no URIs for the bookworm suite in $src" >&2; exit 2; }
    {
        echo "Types: deb"
        echo "URIs: $uris"
        echo "Suites: bookworm-backports"
        echo "Components: main"
        [ -n "$signed" ] && echo "Signed-By: $signed"
    } | $sudo_cmd tee "$dst" >/dev/null
fi

export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -qq
$sudo_cmd apt-get install -y -qq -t bookworm-backports --no-install-recommends kicad >/dev/null
kicad-cli version
