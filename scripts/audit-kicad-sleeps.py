"""Lists every direct nanosleep call in KiCad's in-process modules with its duration.

The DRC-wait preload (pcbdata/kicad/fastwait/fastwait.c) cuts nanosleeps of 100 ms or more made
from these modules to 1 ms. That is safe only if each such call sits in a loop that re-checks
its condition; run this after a KiCad upgrade and read the code around every long call site
(`objdump -d --start-address=...`). KiCad 9.0.8 (Debian 9.0.8+dfsg-1~bpo12+1) has 8 sites, all
in _pcbnew.kiface: 250 ms (DRC track-clearance wait), 100 ms (zone filler wait), 6 x 10 ms.

    python3 scripts/audit-kicad-sleeps.py            (needs objdump, from binutils)
"""
from __future__ import annotations

import glob
import re
import subprocess
import sys

MODULES = ["/usr/lib/kicad/_pcbnew.kiface", *glob.glob("/usr/lib/x86_64-linux-gnu/libkicommon.so.*"),
           *glob.glob("/usr/lib/x86_64-linux-gnu/libkigal.so.*"),
           *glob.glob("/usr/lib/x86_64-linux-gnu/libkicad_*.so.*")]
CALL = re.compile(r"^\s*([0-9a-f]+):\s+call\s+[0-9a-f]+ <(nanosleep|clock_nanosleep|usleep|sleep)@plt>")
CONSTANT = re.compile(r"movdqa\s+0x[0-9a-f]+\(%rip\),%xmm\d+\s+# ([0-9a-f]+)")


def timespec_at(module: str, address: int) -> float | None:
    dump = subprocess.run(["objdump", "-s", f"--start-address={address:#x}",
                           f"--stop-address={address + 16:#x}", module],
                          capture_output=True, text=True, check=True).stdout.splitlines()
    words = [w for w in dump[-1].split()[1:5]] if dump else []
    if len(words) != 4:
        return None
    raw = bytes.fromhex("".join(words))
    return int.from_bytes(raw[:8], "little") + int.from_bytes(raw[8:], "little") / 1e9


def audit(module: str) -> list[tuple[str, str, float | None]]:
    lines = subprocess.run(["objdump", "-d", "--no-show-raw-insn", module], capture_output=True,
                           text=True, check=True).stdout.splitlines()
    sites = []
    for n, line in enumerate(lines):
        match = CALL.match(line)
        if match:
            recent = [CONSTANT.search(l) for l in lines[max(0, n - 12):n]]
            found = [m for m in recent if m]
            seconds = timespec_at(module, int(found[-1].group(1), 16)) if found else None
            sites.append((match.group(1), match.group(2), seconds))
    return sites


def main() -> int:
    for module in MODULES:
        for offset, function, seconds in audit(module):
            duration = "unknown (read the code)" if seconds is None else f"{seconds * 1000:g} ms"
            flag = ("  <- check: cut to 1 ms if >= 100 ms" if seconds is None
                    else "  <- cut to 1 ms by the preload" if seconds >= 0.1 else "")
            print(f"{module} +0x{offset} {function}: {duration}{flag}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
