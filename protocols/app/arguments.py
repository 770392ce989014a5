"""The `dyno` parser's pieces: its error style, the argument types (numbers within their
ranges, lists, the hold-out split, --setup items) and the budgets' bounds."""
from __future__ import annotations

import argparse
import difflib
import math

from protocols.errors import UsageError

BUDGET_S = 120.0  # s: rig time the dyno's own next tests take unless --budget says otherwise
MAX_BUDGET_S = 7200.0  # s: what a run may move without --long (protocols/preflight.py)


class Parser(argparse.ArgumentParser):
    """Usage mistakes are one line, like every other bad input, and exit 2."""

    commands: dict = {}

    def error(self, message):
        where = self.prog.removeprefix("dyno").strip()
        self.exit(2, f"dyno: error: {where + ': ' if where else ''}{message}\n")

    def check_command(self, argv):
        """`dyno` alone lists the commands; a mistyped one is named with the nearest, in one line."""
        if not argv:
            self.exit(2, self.format_help())
        if not argv[0].startswith("-") and argv[0] not in self.commands:
            near = difflib.get_close_matches(argv[0], self.commands, n=1)
            self.error(f"unknown command {argv[0]!r}" + (f"; did you mean {near[0]!r}?" if near else "")
                       + " (dyno alone lists the commands)")


def setup_item(text):
    """--setup KEY=VALUE: a key of letters, digits, '_', '-' or '.', and a value."""
    key, eq, value = text.partition("=")
    if not eq or not value.strip() or not key or not all(c.isalnum() or c in "_-." for c in key):
        raise argparse.ArgumentTypeError(f"{text!r} is not KEY=VALUE (a key of letters, digits, _ - or ., then a value)")
    return key, value.strip()


def number(lo=None, hi=None, integer=False, above=None):
    """An argparse type: a finite number (an integer if asked) within [lo, hi], above `above`."""
    def parse(text):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if integer else 'a number'}") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        if above is not None and not v > above:
            raise argparse.ArgumentTypeError(f"must be above {above:g}, got {text}")
        if lo is not None and v < lo or hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"must be within {'-inf' if lo is None else f'{lo:g}'}.."
                                             f"{'inf' if hi is None else f'{hi:g}'}, got {text}")
        return v
    return parse


def sizes(text):
    """An argparse type: comma-separated positive numbers."""
    try:
        out = [float(v) for v in text.split(",")]
    except ValueError:
        out = []
    if not out or not all(math.isfinite(v) and v > 0 for v in out):
        raise argparse.ArgumentTypeError(f"{text!r}: give positive numbers separated by commas, e.g. 1,3,10")
    return out


def holdout(text):
    """An argparse type: "interleaved", or "tail:F" with 0 < F <= 0.3 (returned as F)."""
    if text == "interleaved":
        return text
    kind, _, frac = text.partition(":")
    if kind == "tail":
        try:
            f = float(frac)
        except ValueError:
            f = math.nan
        if 0 < f <= 0.3:
            return f
    raise argparse.ArgumentTypeError(f"{text!r}: give interleaved or tail:FRACTION with 0 < FRACTION <= 0.3")


def virtual_plant(args):
    """The virtual plant's PlantOptions from --damper, --effect, --plain, --seed (and prove's --noise)."""
    from sim_backend.effects import EffectError
    from sim_backend.options import plant_options
    try:
        return plant_options(args.damper, args.effect, args.plain, args.seed, getattr(args, "noise", 1.0))
    except EffectError as e:
        raise UsageError(str(e)) from None


def cluster_option(p):
    p.add_argument("--cluster", default=None, metavar="local[:N]|tcp://HOST:PORT",
                   help="fan out on Dask distributed (docs/cluster.md; pip install 'dyno[cluster]')")


def unit_system(text):
    """--units: the one place a command's unit system is built."""
    from protocols.units import SYSTEMS, Units
    if text not in SYSTEMS:
        raise argparse.ArgumentTypeError(f"{text!r}: give one of {', '.join(SYSTEMS)}")
    return Units(text)
