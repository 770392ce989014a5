"""`dyno protocols` and `dyno run PROTOCOL --help`: the protocols and their parameters
(defaults from each protocol's Params, units and meanings from protocols/library/params.toml)."""
from __future__ import annotations

from protocols.library import PROTOCOLS, describe


def protocol_help(name):
    """Print a protocol's parameters; False when there is no such protocol."""
    if name not in PROTOCOLS:
        return False
    summary, rows = describe(name)
    print(f"dyno run {name} [name=value ...] [options]: {summary}\n")
    print("parameters (name=value anywhere among the options; lists comma-separated):")
    w = max(len(r[0]) for r in rows)
    d = max(len(r[1]) for r in rows)
    for param, default, unit, meaning in rows:
        print(f"  {param:{w}s}  {default:>{d}s}  {unit:5s}  {meaning}")
    print("\nthe run's options (--rig, --out, --live, ...): dyno run --help")
    return True


def run(args):
    w = max(map(len, PROTOCOLS))
    for name in PROTOCOLS:
        print(f"{name:{w}s}  {describe(name)[0]}")
    print("\nparameters of one: dyno run PROTOCOL --help")
    return 0
