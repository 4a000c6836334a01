"""`pcbdata push DIR --repo OWNER/NAME`: upload a published set to the Hugging Face Hub."""
from __future__ import annotations

VERB = "push"
HELP = "upload a published set to a Hugging Face Hub dataset repository, then tag it"


def register(parser) -> None:
    parser.add_argument("root", metavar="DIR", help="a built and published board set")
    parser.add_argument("--repo", required=True, metavar="OWNER/NAME", help="dataset repository")
    parser.add_argument("--tag", action="append", dest="tags", metavar="vX.Y",
                        help="tag to create (repeatable); default: <family>-v<set version> "
                             "per family")
    parser.add_argument("--private", action="store_true", help="create the repository as private")
    parser.add_argument("--dry-run", action="store_true", help="list what would be uploaded")
    parser.set_defaults(run=run)


def run(args) -> int:
    from pcbdata.publish import push

    push(args.root, args.repo, tags=args.tags, dry_run=args.dry_run, private=args.private)
    return 0
