"""The servo-hydraulic actuator: a position loop (bandwidth, velocity and force limits),
the controller's modes, its command watchdog and its alarms (rig/codecs/actuator.py)."""
from __future__ import annotations

import math

from rig.codecs.actuator import ALARM_BIT, MODES, STATES

MODE_OFF, MODE_HOLD, MODE_FOLLOW = MODES["off"], MODES["hold"], MODES["follow"]
STATE_OFF, STATE_HOLDING, STATE_FOLLOWING, STATE_ALARM = (next(k for k, v in STATES.items() if v == name)
                                                          for name in ("off", "holding", "following", "alarm"))
# stalled against a force beyond its rating, the actuator cannot follow its setpoint
ALARM_FORCE, ALARM_VALVE = ALARM_BIT["following error"], ALARM_BIT["valve fault"]


def target_now(pl):
    """The setpoint [m] now: ramped from the previous one over one command period."""
    frac = min((pl.t - pl.last_command_t) / pl.cmd_period, 1.0)
    return pl.setpoint_from + (pl.setpoint - pl.setpoint_from) * frac


def velocity(pl):
    """The piston's velocity [m/s] this step: the position loop towards the setpoint (or the
    hold position), limited; zero with the valve closed (off, alarm) or stalled against a
    force beyond the rating. Applies the command watchdog and raises alarms."""
    a = pl.p["actuator"]
    if pl.t - pl.last_command_t > a["command_timeout_s"] and pl.mode == MODE_FOLLOW:
        pl.mode, pl.hold_at = MODE_HOLD, pl.x_act  # lost controller: hold
    if "actuator_alarm" in pl.faults:
        pl.alarm |= ALARM_VALVE
    if pl.alarm or pl.mode == MODE_OFF:
        target = None
    else:
        target = target_now(pl) if pl.mode == MODE_FOLLOW else pl.hold_at
    if target is None:
        v = 0.0  # valve closed: the oil column locks the piston
    else:
        v = 2 * math.pi * a["bandwidth_hz"] * (target - pl.x_act)
        v = min(max(v, -a["velocity_max"]), a["velocity_max"])
    if abs(pl.F) > a["force_max"] and v * pl.F > 0:
        v = 0.0  # stalled against the damper
        pl.alarm |= ALARM_FORCE
    return v
