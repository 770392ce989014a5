"""A closed-loop plan's pre-flight: what the rig will do depends on what it measures, so
the whole run is first made offline, through the real runner, against the virtual plant
(sim_backend/plant.toml) with the damper model, and refused if it would trip (a limit,
the stability guard)."""
from __future__ import annotations

from rig.pacing import SimulatedPacer
from rig.safety import Safety
from sim_backend.direct_rig import DirectRig

from protocols import runner
from protocols.plan import ParamError


def rehearse(module, params, info, cfg, damper):
    """[(segment, measures)] of the offline run; ParamError with the trip that ended it."""
    rig = DirectRig(cfg, damper)
    result, _ = runner.run(module, params, info, rig, SimulatedPacer(rig, cfg.rate_hz), Safety(cfg), progress=False)
    if result.fault:
        raise ParamError(f"pre-flight: the run against the virtual plant with the damper model stops: {result.fault}")
    return result.measures
