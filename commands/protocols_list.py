"""`dyno protocols` and `dyno run PROTOCOL --help`: the protocols and their parameters
(defaults from each protocol's Params, units and meanings from protocols/library/params.toml)."""
from __future__ import annotations

import tomllib


def add(sub):
    """The `dyno protocols_list` command's arguments."""
    sub.add_parser("protocols", help="the test protocols, each in a line").set_defaults(command="protocols_list")


def _discover():
    """(summary, rows) of `dyno run discover`: the sine matrix's parameters with the
    opening's defaults (the matrix the diagnosis is proven on)."""
    from protocols.library import DESCRIPTIONS, DISCOVER, describe
    from protocols.proven import opening as proven
    opening = proven()[1]
    rows = [(p, ",".join(f"{v:g}" for v in opening[p]) if isinstance(opening.get(p), list)
             else str(opening.get(p, default)), unit, meaning) for p, default, unit, meaning in describe("sine-matrix")[1]]
    return tomllib.loads(DESCRIPTIONS.read_text())[DISCOVER]["summary"], rows


def protocol_help(name):
    """Print a protocol's parameters; False when there is no such protocol."""
    from protocols.library import DISCOVER, PROTOCOLS, describe
    if name not in PROTOCOLS and name != DISCOVER:
        return False
    summary, rows = _discover() if name == DISCOVER else describe(name)
    print(f"dyno run {name} [name=value ...] [options]{' [--budget SECONDS]' if name == DISCOVER else ''}: "
          f"{summary}\n")
    print("parameters (name=value anywhere among the options; lists comma-separated):")
    w = max(len(r[0]) for r in rows)
    d = max(len(r[1]) for r in rows)
    for param, default, unit, meaning in rows:
        print(f"  {param:{w}s}  {default:>{d}s}  {unit:5s}  {meaning}")
    print("\nthe run's options (--rig, --out, --live, ...): dyno run --help")
    return True


def run(args):
    from protocols.library import DESCRIPTIONS, DISCOVER, PROTOCOLS, describe
    w = max(map(len, PROTOCOLS))
    for name in PROTOCOLS:
        print(f"{name:{w}s}  {describe(name)[0]}")
    print(f"{DISCOVER:{w}s}  {tomllib.loads(DESCRIPTIONS.read_text())[DISCOVER]['summary']}")
    print("\nparameters of one: dyno run PROTOCOL --help")
    return 0
