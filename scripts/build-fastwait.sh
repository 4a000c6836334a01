#!/usr/bin/env bash
# Builds build/fastwait/libpcbdata_fastwait.so from pcbdata/kicad/fastwait/fastwait.c: the
# preload that cuts KiCad's 250 ms DRC polling sleep short (DEVELOPERS.md, "KiCad's DRC polling
# wait"). Idempotent: rebuilds only when the source is newer. Optional: without a C compiler
# KiCad workers just run without it (same results, slower DRC of routed boards).
set -euo pipefail
cd "$(dirname "$0")/.."

src=pcbdata/kicad/fastwait/fastwait.c
out=build/fastwait/libpcbdata_fastwait.so
cc="${CC:-gcc}"

if [ -f "$out" ] && [ "$out" -nt "$src" ]; then
    exit 0
fi
if ! command -v "$cc" >/dev/null 2>&1; then
    echo "build-fastwait: no C compiler ($cc); KiCad workers will run without the DRC wait fix" >&2
    exit 0
fi
mkdir -p "$(dirname "$out")"
# Compile to a temporary name and rename, so a worker starting meanwhile never preloads half a file.
tmp="$(mktemp "$out.XXXXXX")"
trap 'rm -f "$tmp"' EXIT
"$cc" -O2 -Wall -Wextra -Werror -fPIC -shared -o "$tmp" "$src" -ldl
chmod 644 "$tmp"
mv -f "$tmp" "$out"
trap - EXIT
echo "build-fastwait: built $out"
