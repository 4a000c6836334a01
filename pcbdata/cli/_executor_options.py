"""`--executor` and `--ray-address`: where a verb's tasks run (`pcbdata.executors`).

A verb adds them with `add(parser)` and hands `executor(args)` to its library function:

    _executor_options.add(parser)                                        # in register()
    build_level(..., "d2", executor=_executor_options.executor(args))             # in run()
"""
from __future__ import annotations

import os

from pcbdata.executors import EXECUTORS


def add(parser) -> None:
    group = parser.add_argument_group("where tasks run")
    group.add_argument("--executor", choices=EXECUTORS, default="local",
                       help="local: this machine's worker processes (default); ray: one Ray "
                            "task per board on a Ray cluster (needs pcbdata[ray]; the same "
                            "output, byte for byte; see docs/ray.md)")
    group.add_argument("--ray-address", default=os.environ.get("RAY_ADDRESS") or None,
                       metavar="ADDRESS",
                       help="the Ray cluster to join, e.g. HEAD_IP:6379 (default: RAY_ADDRESS; "
                            "without either: one `ray start` began on this machine, else a new "
                            "Ray instance on this machine)")


def executor(args):
    """The `pcbdata.executors.Executor` the parsed options name."""
    from pcbdata.executors import get_executor

    return get_executor(args.executor, args.ray_address)
