"""`dyno bench diagnose --crank`: the diagnosis's time on what a crank dyno records (issue
47's case): the plain plant driven by a slider-crank through four speeds, 100 s at 300 Hz,
with five effects hidden in it, so the diagnosis runs several rounds with several effects
accepted, as on a real crank-dyno file."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from types import SimpleNamespace

from rig.errors import UsageError

CRANK_M = (0.025, 0.15)  # m: crank radius (a 50 mm stroke) and connecting rod
CRANK_HZ = (0.5, 1.0, 2.0, 3.0)  # the crank's speeds, one segment each (peak 0.5 m/s)


@dataclass
class CrankParams:
    seconds: float = 100.0


def crank_x(theta, r, rod):
    """Slider-crank displacement [m] from its top at crank angle theta [rad]."""
    return r * (1 - math.cos(theta)) + rod - math.sqrt(rod ** 2 - (r * math.sin(theta)) ** 2)


def _plan(params, info):
    from protocols.plan import Segment
    r, rod = CRANK_M
    x0 = info.x_mid - r  # the stroke about mid-stroke
    yield Segment("to the crank's top", {}, 2.0, lambda t: info.x_mid + (x0 - info.x_mid) * min(t / 2.0, 1.0), False)
    for f in CRANK_HZ:  # whole turns: each speed starts where the last ended
        turns = max(round(params.seconds / len(CRANK_HZ) * f), 2)
        yield Segment(f"crank {2 * r * 1e3:g} mm {f:g} Hz", {"amplitude_mm": r * 1e3, "freq_hz": f}, turns / f,
                      lambda t, f=f: x0 + crank_x(2 * math.pi * f * t, r, rod), kind="sine")


def recording(seconds=100.0, rate_hz=300.0, seed=0):
    """(channels, events) of the crank run on the plain plant with its effects hidden
    (sim_backend/plain.toml [bench.crank]; no wires)."""
    from protocols import cell, runner
    from protocols.plan import Plan
    from rig import config as rig_config
    from sim_backend.options import PlantOptions, benchmark, plain_cell
    name, params, _ = plain_cell()
    cfg = rig_config.at_rate(rig_config.load("virtual"), rate_hz)
    module = SimpleNamespace(NAME="crank", check=lambda p, i: [], plan=_plan)
    kept = runner.Kept()
    with cell.direct(cfg, name, PlantOptions(name, benchmark("crank"), params, seed)) as c:
        result = runner.run_plan(Plan(module, CrankParams(seconds)), c, [kept])
    if result.fault:
        raise UsageError(f"bench diagnose --crank: the crank run tripped: {result.fault}")
    # what a crank dyno records of a racing damper: no coil, no valve command (the virtual
    # cell's adjuster current would let every effect be tried scaled by it as well)
    return {n: c for n, c in kept.arrays().items() if not n.startswith("aux.")}, kept.events


def bench(seconds=100.0, rate_hz=300.0, runs=3):
    from workers import threads
    from models.diagnose import diagnose
    from proof.bench.throughput import repeated
    from sim_backend.options import benchmark
    t0 = time.perf_counter()
    ch, events = recording(seconds, rate_hz)
    t_rec = time.perf_counter() - t0
    res, walls = repeated(lambda: diagnose(ch, events, jobs=threads.cores()), runs)
    return {"recording": "slider-crank", "recording_s": float(ch["force"][0][-1] - ch["force"][0][0]),
            "rate_hz": rate_hz, "samples": int(len(ch["force"][0])), "hidden": sorted(benchmark("crank")),
            "make_recording_s": t_rec, **walls, "accepted": res.accepted, "named": res.named(),
            "goal_s": 5.0, "timing": res.timing}
