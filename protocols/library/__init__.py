"""The test protocols, one short file each (thesis chapter 2), hardware-in-the-loop and replay."""
import dataclasses
import tomllib
from pathlib import Path

from protocols.library import hil, low_speed, replay, sine_matrix, standard, static, step, temperature_sweep

PROTOCOLS = {m.NAME: m for m in (static, low_speed, sine_matrix, temperature_sweep, step, standard, hil, replay)}
DESCRIPTIONS = Path(__file__).parent / "params.toml"
DISCOVER = "discover"  # not a plan: an opening sine matrix, then the dyno's own tests (protocols/discover.py)


def describe(name):
    """(summary, [(parameter, default, unit, meaning)]) of a protocol: defaults from its
    Params, units and meanings from params.toml."""
    doc = tomllib.loads(DESCRIPTIONS.read_text())[name]
    rows = []
    for f in dataclasses.fields(PROTOCOLS[name].Params):
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        unit, _, meaning = doc["params"][f.name].partition(" | ")
        rows.append((f.name, ",".join(f"{v:g}" for v in default) if isinstance(default, list) else f"{default}",
                     unit, meaning))
    return doc["summary"], rows
