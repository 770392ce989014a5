"""Cavitation: a chamber whose pressure would fall below where the oil releases air holds
there instead, and the piston loses that push (a hard floor; air that redissolves with a
lag; a floor approached softly)."""
from __future__ import annotations

import math

from sim_backend.effects.base import Hidden

CAV_REDISSOLVE_S = 0.005  # s: how fast released air goes back into solution (a choice)


class Cavitation(Hidden):
    name = "cavitation"
    listed = 100
    unit = "Pa"
    form = "absolute pressure below which the oil releases air: chambers cannot go lower"
    guess = 3e5
    hi = 1e7
    forms = {"lingering": "the air released below VALUE redissolves over CAV_REDISSOLVE_S: the lost push recovers "
                          "with that lag",
             "soft": "air comes out of solution from twice VALUE down: the chamber approaches VALUE exponentially"}
    stage = 60

    def start(self, pl):
        self.loss = (0.0, 0.0)  # pressure the released air still holds per chamber [Pa]

    def load(self, pl, s):
        geo, floor, form = pl.damper.geometry, self.value, self.variant
        P1, P2 = s.P1, s.P2
        P1c, P2c = floored(P1, floor, form), floored(P2, floor, form)
        if form == "lingering":  # the released air redissolves over CAV_REDISSOLVE_S
            keep = math.exp(-s.h / CAV_REDISSOLVE_S)
            self.loss = (max(P1c - P1, self.loss[0] * keep), max(P2c - P2, self.loss[1] * keep))
            P1c, P2c = P1 + self.loss[0], P2 + self.loss[1]
        s.F += (P1c - P1) * geo.A_p - (P2c - P2) * (geo.A_p - geo.A_r)
        s.P1, s.P2 = P1c, P2c


def floored(P, floor, form=None):
    """A chamber's pressure [Pa] where the oil releases air at `floor` [Pa]: held at the
    floor, or (soft) approaching it exponentially from twice the floor down."""
    if form == "soft":
        return P if P >= 2 * floor else floor + floor * math.exp((P - 2 * floor) / floor)
    return max(P, floor)
