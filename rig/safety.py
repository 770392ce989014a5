"""Safety limits and the watchdog, checked every control tick.

check() returns the first reason to trip, in plain words, or None. What a trip does is
the control loop's (rig/loop.py): hold, then a slow move to the safe position when
position feedback and the actuator are healthy, fault latched.
"""
from __future__ import annotations

from rig.config import RigConfig
from rig.devices import TRANSPORTS

# channel -> (limit key, test, words); values in SI
RANGE_CHECKS = (
    ("x", lambda v, L: not L["x_min"] <= v <= L["x_max"], "displacement {v:.4f} m outside {lo:.4f}..{hi:.4f} m"),
    ("force", lambda v, L: abs(v) > L["force_max"], "force {v:.0f} N beyond +-{f:.0f} N"),
    ("v", lambda v, L: abs(v) > L["velocity_max"], "velocity {v:.2f} m/s beyond +-{vm:.2f} m/s"),
    ("T_body", lambda v, L: v > L["temperature_max"], "damper body at {c:.0f} C, above {tm:.0f} C"),
    ("T_reservoir", lambda v, L: v > L["temperature_max"], "reservoir at {c:.0f} C, above {tm:.0f} C"),
    ("P_gas", lambda v, L: v > L["gas_pressure_max"], "gas pressure {mpa:.2f} MPa above {pm:.2f} MPa"),
)


class Safety:
    def __init__(self, config: RigConfig):
        self.config = config
        self.L = config.limits
        # how old a channel's latest reading may be: stale_s, or what its transport needs
        # (a polled module's reading, 10 poll periods)
        self.max_age = {}
        for ch in config.channels.values():
            d = config.devices[ch.device]
            self.max_age[ch.name] = TRANSPORTS[d.transport].max_age(d.params, self.L["stale_s"])
        self._force = None  # (value, since when) to spot a frozen load cell
        self.started = None  # first check: a channel that never reported is stale from then

    def _frozen_force(self, readings):
        """A real load cell's reading always moves by its noise; an identical value for
        0.1 s while the damper moves means the amplifier or its link is stuck."""
        f, v = readings.get("force"), readings.get("v")
        if f is None:
            return None
        # timed by the readings' own stamps: a stall of the loop (99.5 ms once in CI) brings no
        # new reading, and the last one is not a frozen amplifier
        if self._force is None or f.value != self._force[0]:
            self._force = (f.value, f.t)
            return None
        if v is not None and abs(v.value) > 0.02 and f.t - self._force[1] > 0.1:
            return f"force ({self.config.channels['force'].device}): reading frozen at {f.value:.1f} N while moving"
        return None

    def check(self, readings: dict, now: float, actuator=("unknown", []), trouble=lambda device: ""):
        """First reason to trip, or None. now: the rig's clock, on which readings are
        stamped (a channel that has never reported is stale once its allowed age has
        passed since the first check); trouble(device): what the device knows is wrong,
        said with a stale channel of it (which of the two trips first is a race)."""
        if self.started is None:
            self.started = now
        for name, ch in self.config.channels.items():
            r = readings.get(name)
            last = r.t if r is not None else self.started
            if now - last > self.max_age[name]:
                what = "no data" if r is None else f"no new data for {1e3 * (now - r.t):.0f} ms"
                why = trouble(ch.device)
                return (f"watchdog: {name} ({ch.device}): {what} (limit {1e3 * self.max_age[name]:.0f} ms)"
                        + (f": {why}" if why else ""))
            if r is not None and r.fault:
                return f"{name} ({ch.device}): {r.fault}"
        frozen = self._frozen_force(readings)
        if frozen:
            return frozen
        state, alarms = actuator
        if state == "alarm" or alarms:
            return f"actuator alarm: {', '.join(alarms) or 'unspecified'}"
        for name, test, _ in RANGE_CHECKS:
            r = readings.get(name)
            if r is not None and (r.value != r.value or test(r.value, self.L)):
                return "limit: " + self.beyond_limit(name, r.value)
        return None

    def beyond_limit(self, name, value):
        """The words for a reading beyond its safety limit, or None (also for NaN: a
        reading that is not a number is beyond every limit)."""
        L = self.L
        for channel, test, words in RANGE_CHECKS:
            if channel == name and (value != value or test(value, L)):
                return words.format(v=value, lo=L["x_min"], hi=L["x_max"], f=L["force_max"], vm=L["velocity_max"],
                                    c=value - 273.15, tm=L["temperature_max"] - 273.15, mpa=value / 1e6,
                                    pm=L["gas_pressure_max"] / 1e6)
        return None

    def setpoint_ok(self, x):
        return self.L["x_min"] <= x <= self.L["x_max"]
