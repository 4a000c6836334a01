"""`pcbdata publish DIR`: parquet shards, pictures and the dataset card of a built set."""
from __future__ import annotations

from pcbdata.cli import _checks as checks

VERB = "publish"
HELP = "make a built set loadable with datasets.load_dataset (parquet shards, card, pictures)"


def register(parser) -> None:
    parser.add_argument("root", metavar="DIR", help="a built board set (with manifest.json)")
    parser.add_argument("--config", action="append", dest="configs", metavar="CONFIG",
                        help="rewrite this config even if it is up to date (repeatable); the "
                             "other configs are written only when missing or stale")
    parser.add_argument("--previews", type=checks.non_negative, default=3, metavar="N",
                        help="board previews per config on the card (default 3; 0: none)")
    parser.add_argument("--force", action="store_true", help="rewrite every config")
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.publish import publish_set

    publish_set(args.root, args.configs, previews=args.previews, force=args.force, log=print)
    print(f"published {args.root}: datasets.load_dataset({str(args.root)!r}, CONFIG, split=SPLIT)")
    return 0
