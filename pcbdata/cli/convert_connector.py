"""`pcbdata convert-connector`: Connector solutions (grid-action agents) to routed D1 boards."""
from __future__ import annotations

VERB = "convert-connector"
HELP = ("write a D1 split's Connector solutions (final grids or cell paths, .npz) as routed "
        "boards that pcbdata eval scores")


def register(parser) -> None:
    parser.add_argument("dir", metavar="SET", help="a built D1 board set (with <split>.npz)")
    parser.add_argument("--config", required=True, help="D1 config, e.g. d1-g10")
    parser.add_argument("--split", default="test", help="split name (default: test)")
    parser.add_argument("--solutions", required=True, metavar="FILE.npz",
                        help="grids [M, G, G] or [M, K, G, G] (Jumanji Connector's final "
                             "state), or paths [M, A, L, 2] / [M, K, A, L, 2] padded with -1; "
                             "optional board_ids [M] and time_s [M] or [M, K] (docs/d1.md)")
    parser.add_argument("--out", required=True, metavar="RUNS",
                        help="RUNS/<board_id>/<k>.kicad_pcb (+ <k>.json with time_s)")
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.baselines.connector import convert_rollouts

    counts = convert_rollouts(args.dir, args.config, args.split, args.solutions, args.out)
    print(f"done: {counts['rollouts']} rollouts on {counts['boards']} boards written to "
          f"{args.out}; {counts['connected']} of {counts['agents']} agents connected")
    return 0
