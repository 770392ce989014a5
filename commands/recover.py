"""`dyno recover FILE`: rebuild a recording cut short."""
from __future__ import annotations


def add(sub):
    """The `dyno recover` command's arguments."""
    rv = sub.add_parser("recover", help="rebuild a recording cut short (the original is kept as FILE.damaged)")
    rv.add_argument("file")
    rv.set_defaults(command="recover")


def run(args):
    from views import run_index
    from records.recorder import recover
    r = recover(args.file)
    if r["intact"]:
        print(f"{args.file}: intact, nothing to recover")
    else:
        print(f"{args.file}: recovered {r['messages']} messages, {r['metadata']} metadata, "
              f"{r['attachments']} attachments; the damaged original is {r['damaged']}")
        print(run_index.add(args.file))
    return 0
