"""Benchmark helpers: wall time and peak memory of a whole process tree (parent + workers)."""
from __future__ import annotations

import os
import platform
import subprocess
import threading
import time
from datetime import date


def _tree_rss_kib(root_pid: int) -> int:
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as handle:
                ppid = int(handle.read().rsplit(")", 1)[1].split()[1])
            with open(f"/proc/{name}/status") as handle:
                kib = next((int(line.split()[1]) for line in handle
                            if line.startswith("VmRSS:")), 0)
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(ppid, []).append(int(name))
        rss[int(name)] = kib
    total, stack = 0, [root_pid]
    while stack:
        pid = stack.pop()
        total += rss.get(pid, 0)
        stack.extend(children.get(pid, []))
    return total


def run_measured(command: list[str], **kwargs) -> dict:
    """Runs a command; returns seconds, peak RSS of its process tree (MiB) and its output."""
    start = time.perf_counter()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               **kwargs)
    peak = 0
    stop = threading.Event()

    def sample() -> None:
        nonlocal peak
        while not stop.is_set():
            peak = max(peak, _tree_rss_kib(process.pid))
            time.sleep(0.05)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    stdout, stderr = process.communicate()
    stop.set()
    sampler.join()
    if process.returncode != 0:
        raise RuntimeError(f"{command} failed ({process.returncode}):\n{stderr[-2000:]}")
    return {"seconds": time.perf_counter() - start, "peak_mib": peak / 1024, "stdout": stdout}


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo")
                if line.startswith("model name")), platform.processor())
    mem_gib = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2 ** 30
    return (f"{os.cpu_count()} cores ({cpu}), {mem_gib:.0f} GiB, "
            f"{platform.system()} {platform.release()}; {date.today()}")


def report(result: dict, json_path: str | None) -> None:
    """Prints the figures as JSON and writes them to `json_path` when given."""
    import json
    from pathlib import Path

    text = json.dumps(result, indent=1, sort_keys=True, default=str)
    print(text)
    if json_path:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(text + "\n")


def board_arguments(parser) -> None:
    """The arguments of a benchmark over one split of a built set: SET, --config, --split and
    --boards (`chosen_boards`)."""
    parser.add_argument("set")
    parser.add_argument("--config", required=True)
    parser.add_argument("--split", default="test")
    parser.add_argument("--boards", nargs="*", help="board ids or name endings (default: all)")


def chosen_boards(names: list[str], boards: list[str] | None) -> list[str]:
    """`names` whose name is, or ends with, one of `boards` (all of them without `boards`)."""
    if not boards:
        return names
    return [n for n in names if any(n == b or n.endswith(b) for b in boards)]
