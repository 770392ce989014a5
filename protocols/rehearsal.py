"""A closed-loop plan's pre-flight: what the rig will do depends on what it measures, so
the whole run is first made offline, through the real runner, against the virtual plant
(sim_backend/plant.toml) with the damper model, and refused if it would trip (a limit,
the stability guard)."""
from __future__ import annotations

from protocols import cell
from protocols.plan import ParamError, Plan
from protocols.runner import run_plan


def rehearse(module, params, cfg, damper):
    """[(segment, measures)] of the offline run; ParamError with the trip that ended it."""
    with cell.direct(cfg, damper) as c:
        result = run_plan(Plan(module, params), c)
    if result.fault:
        raise ParamError(f"pre-flight: the run against the virtual plant with the damper model stops: {result.fault}")
    return result.measures
