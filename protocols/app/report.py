"""`dyno report FILE.mcap --out DIR`: the recording's HTML report."""
from __future__ import annotations

from protocols.io.files import make_dir
from protocols.reports.recording import report


def run(args):
    make_dir(args.out)
    index, pngs = report(args.file, args.out)
    for p in pngs:
        print(p)
    print(index)
    return 0
