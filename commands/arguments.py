"""The `dyno` parser's pieces: its error style, the argument types (numbers within their
ranges, lists, the hold-out split, --setup items), the budgets' bounds and the options
several commands declare alike. Each command declares its own options beside it (its
module's add())."""
from __future__ import annotations

import argparse
import difflib
import math

from rig.errors import UsageError

BUDGET_S = 120.0  # s: rig time the dyno's own next tests take unless --budget says otherwise
MAX_BUDGET_S = 7200.0  # s: what a run may move without --long (protocols/preflight.py)


class Parser(argparse.ArgumentParser):
    """Usage mistakes are one line, like every other bad input, and exit 2."""

    commands: dict = {}

    def error(self, message):
        where = self.prog.removeprefix("dyno").strip()
        self.exit(2, f"dyno: error: {where + ': ' if where else ''}{message}\n")

    def check_command(self, argv):
        """`dyno` alone lists the commands and ends in the one line saying none was given; a
        mistyped one is named with the nearest, in one line."""
        if not argv:
            self.exit(2, self.format_help() + "dyno: error: no command given: dyno COMMAND, one of those above "
                                              "(dyno COMMAND --help for its options)\n")
        if not argv[0].startswith("-") and argv[0] not in self.commands:
            near = difflib.get_close_matches(argv[0], self.commands, n=1)
            self.error(f"unknown command {argv[0]!r}" + (f"; did you mean {near[0]!r}?" if near else "")
                       + " (dyno alone lists the commands)")


def negative_values(p, argv) -> list:
    """argv with each negative-looking value of an option that takes one joined to it
    (`--tolerance -5%` as `--tolerance=-5%`): argparse reads a value starting with '-' as an
    option, and said "expected one argument" where the value's own check names what is wrong."""
    takes = set()
    stack = [p]
    while stack:
        q = stack.pop()
        for a in q._actions:
            if isinstance(a, argparse._SubParsersAction):
                stack += list(a.choices.values())
            elif a.option_strings and a.nargs is None and not isinstance(a, argparse._StoreConstAction):
                takes.update(o for o in a.option_strings if o.startswith("--"))
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else ""
        if a in takes and len(nxt) > 1 and nxt[0] == "-" and (nxt[1].isdigit() or nxt[1] in ".i"):
            out.append(f"{a}={nxt}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def setup_item(text):
    """--setup KEY=VALUE: a key of letters, digits, '_', '-' or '.', and a value."""
    key, eq, value = text.partition("=")
    if not eq or not value.strip() or not key or not all(c.isalnum() or c in "_-." for c in key):
        raise argparse.ArgumentTypeError(f"{text!r} is not KEY=VALUE (a key of letters, digits, _ - or ., then a value)")
    return key, value.strip()


def identity(p, what="test"):
    """Who ran the test on which damper and how it was set up: recorded in the run's
    metadata, shown on the report and kept in the catalogue (run and import alike)."""
    p.add_argument("--operator", default=None, help=f"who ran the {what} (recorded, shown on the report)")
    p.add_argument("--serial", default=None, help="the damper's serial number (recorded, shown on the report)")
    p.add_argument("--note", default=None, help="a note for the record (setup, clickers, ...)")
    p.add_argument("--setup", action="append", type=setup_item, default=[], metavar="KEY=VALUE",
                   help="the damper's setup, recorded and shown on the report (repeat: --setup clicks_reb=12 "
                        "--setup gas_bar=10)")


def reference(p, required=False):
    """--against and --tolerance: what a run is checked against (dyno check, the report's sheet)."""
    p.add_argument("--against", required=required, default=None, metavar="REF.mcap|MODEL|TABLE",
                   help="the reference: another run, a damper model (preset or FILE.json) simulated along "
                        "this run's motion, or a force-velocity table (a spec sheet, another dyno's export, a "
                        "report's velocity.csv; .csv/.txt/.xlsx, units in the column names)")
    from protocols.units import TOLERANCE
    p.add_argument("--tolerance", default=None,
                   help=f"the band, with its unit: 5%% of the reference, 50N, 11lbf, or 5%%,50N (the larger; default "
                        f"{TOLERANCE.replace('%', '%%')}; runs that sweep a --setup setting get no pass/fail without it "
                        f"or --against)")


def identity_info(args) -> dict:
    """identity()'s options as the run metadata's fields (operator, damper_serial, note,
    setup.KEY), those given only."""
    who = {"operator": "operator", "damper_serial": "serial", "note": "note"}  # metadata "run" <- --option
    return {**{k: getattr(args, a) for k, a in who.items() if getattr(args, a, None)},
            **{f"setup.{k}": v for k, v in getattr(args, "setup", None) or []}}


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


# --- the options several commands declare alike ---

FILE, FOLDER = "file", "folder"  # what an output option names (commands/output.py checks it)


def writes(p, flag, kind, **kw):
    """An option naming a file or folder the command writes: main() checks it by the one
    rule (records/files.py) before the command starts, whatever the command does."""
    action = p.add_argument(flag, **kw)
    action.writes = kind
    return action


def overwrite(p, what="the output"):
    p.add_argument("--overwrite", action="store_true",
                   help=f"replace {what} if it exists (never an input; a folder's other files are kept)")


def units(p):
    p.add_argument("--units", type=unit_system, default="metric", metavar="{si,metric,us}",
                   help="the unit system shown: si (m, m/s, N, Pa, K), metric (mm, mm/s, N, bar gauge, C; the "
                        "default) or us (in, in/s, lbf, psi gauge, F)")


def hidden_physics(p):
    # not listed here: their catalogue's import would cost every dyno command a second
    p.add_argument("--effect", action="append", metavar="NAME=VALUE",
                   help="hide physics in the virtual rig, e.g. compressibility=0.5 (docs/diagnosis.md; an unknown "
                        "NAME lists the effects)")
    p.add_argument("--plain", action="store_true",
                   help="the plain cell dyno prove uses (sim_backend/plain.toml): nothing the minimal model leaves out")
    p.add_argument("--seed", type=number(0, 2**32 - 1, integer=True), default=0,
                   help="the virtual rig's noise seed (default 0)")


def batch_options(p, what, beside):
    p.add_argument("--batch", nargs="+", metavar="FILE",
                   help=f"many recordings, one task each: {beside} beside each and a summary table")
    writes(p, "--summary", FILE, default=None, help=f"--batch's summary CSV (default {what}-summary.csv)")
    cluster_option(p)
    p.add_argument("--jobs", type=number(1, 256, integer=True), default=2,
                   help="--batch without --cluster: recordings analysed in parallel (default 2)")
