"""`dyno recover FILE`: rebuild a recording cut short."""
from __future__ import annotations

from protocols import catalogue
from protocols.io.recording import recover


def run(args):
    r = recover(args.file)
    if r["intact"]:
        print(f"{args.file}: intact, nothing to recover")
    else:
        print(f"{args.file}: recovered {r['messages']} messages, {r['metadata']} metadata, "
              f"{r['attachments']} attachments; the damaged original is {r['damaged']}")
        print(catalogue.add(args.file))
    return 0
