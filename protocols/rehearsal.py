"""A closed-loop plan's pre-flight: what the rig will do depends on what it measures, so
the whole run is first made offline, through the real runner, and refused if it would trip
(a limit, the stability guard): on the virtual rig against the virtual plant
(sim_backend/plant.toml) with the damper model; on a real cell against the damper model
alone (protocols.cell.model), so no file of the simulator is opened for it."""
from __future__ import annotations

from protocols import cell
from protocols.plan import ParamError, Plan
from protocols.runner import run_plan


AGAINST = {True: "the virtual plant", False: "the damper model alone"}  # what a rehearsal runs on


def rehearse(module, params, cfg, damper, virtual=True):
    """[(segment, measures)] of the offline run (virtual: on the virtual plant, else on the
    damper model alone); ParamError with the trip that ended it."""
    with (cell.direct(cfg, damper) if virtual else cell.model(cfg, damper)) as c:
        result = run_plan(Plan(module, params), c)
    if result.fault:
        raise ParamError(f"pre-flight: the run against {AGAINST[virtual]} stops: {result.fault}")
    return result.measures
