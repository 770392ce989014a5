"""What a trip does, as an explicit state machine the control loop drives once a tick.

    running --trip(reason, x)--> moving   (position feedback and actuator healthy)
    running --trip(reason)-----> holding  (feedback or actuator not to be trusted)
    moving  --reached----------> settling
    moving  --cannot_move()----> holding  (a later error while moving)
    holding ------------------> settling
    settling --SETTLE_S passed--> done

step(t) says what to command this tick: ("follow", x), ("hold", None) or (None, None)
once done. The first reason is the one kept: a later error while stopping never hides
the error that caused the stop.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

SAFE_SPEED = 0.01  # m/s: the controlled move to the safe position
SETTLE_S = 0.2  # s: hold at the safe position (or where it stopped) before returning


@dataclass
class SafeStop:
    safe_position: float  # m
    speed: float = SAFE_SPEED
    settle_s: float = SETTLE_S
    state: str = "running"
    reason: str | None = None
    x0: float | None = None  # where the move started [m]
    t0: float | None = None  # when it started [s]
    t_settled: float | None = None
    last: tuple = ("hold", None)  # the command repeated while settling

    @property
    def running(self):
        return self.state == "running"

    @property
    def done(self):
        return self.state == "done"

    def trip(self, reason, x=None):
        """Stop for `reason`; x: the measured position when it can be trusted to move the
        actuator to the safe position, else None (just hold, also when already moving)."""
        if self.reason is None:
            self.reason = reason
        trusted = x is not None and math.isfinite(x)
        if self.state == "running":
            if trusted:
                self.state, self.x0 = "moving", float(x)
            else:
                self.state = "holding"
        elif not trusted:  # a later error that leaves the position untrusted
            self.cannot_move()

    def cannot_move(self):
        """A later error while moving: hold where it is."""
        if self.state == "moving":
            self.state = "holding"
        elif self.state == "settling":
            self.last = ("hold", None)

    def step(self, t):
        """(command, setpoint) for this tick at time t [s]."""
        if self.state == "moving":
            if self.t0 is None:
                self.t0 = t
            travel = self.speed * (t - self.t0)
            gap = self.safe_position - self.x0
            if abs(gap) <= travel:
                self.state, self.t_settled = "settling", t + self.settle_s
                self.last = ("follow", self.safe_position)
            else:
                self.last = ("follow", self.x0 + math.copysign(travel, gap))
            return self.last
        if self.state == "holding":
            self.state, self.t_settled, self.last = "settling", t + self.settle_s, ("hold", None)
            return self.last
        if self.state == "settling":
            if t >= self.t_settled:
                self.state = "done"
                return None, None
            return self.last
        return None, None
