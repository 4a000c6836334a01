"""`pcbdata materialize SOURCE... --out DIR2`: rows of published sets or parquet shards back
to board folders that KiCad opens (`DIR2/<config>/<split>/<board_id>/`)."""
from __future__ import annotations

VERB = "materialize"
HELP = "write the rows of a published set (or parquet shards) back as KiCad board folders"


def register(parser) -> None:
    parser.add_argument("sources", nargs="+", metavar="DIR_OR_PARQUET",
                        help="a published set folder, or parquet shard files")
    parser.add_argument("--out", required=True, metavar="DIR2", help="folder to write boards into")
    parser.add_argument("--config", action="append", dest="configs", metavar="CONFIG",
                        help="only this config (repeatable)")
    parser.add_argument("--split", action="append", dest="splits", metavar="SPLIT",
                        help="only this split (repeatable)")
    parser.add_argument("--board", action="append", dest="boards", metavar="BOARD_ID",
                        help="only this board (repeatable)")
    parser.add_argument("--flat", action="store_true",
                        help="write DIR2/<board_id>/ instead of DIR2/<config>/<split>/<board_id>/")
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.publish import materialize

    result = materialize(args.sources, args.out, configs=args.configs, splits=args.splits,
                         board_ids=args.boards, layout="flat" if args.flat else "tree")
    print(f"wrote {result['written']} boards to {args.out}")
    if result["recipes"]:
        print(f"skipped {len(result['recipes'])} recipe rows (not redistributable; "
              f"`pcbdata build d3` restores them): {', '.join(result['recipes'][:5])}"
              + (" ..." if len(result["recipes"]) > 5 else ""))
    return 0
