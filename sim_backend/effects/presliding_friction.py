"""The seal's pre-sliding: its friction builds over a small travel before it slides (the
plant's own Dahl law over VALUE; one elasto-plastic element; four in parallel)."""
from __future__ import annotations

import numpy as np

from sim_backend.effects.base import Hidden

IWAN = (0.25, 0.75, 1.25, 1.75)  # the iwan form's elements' stick travels, in VALUEs


class PreslidingFriction(Hidden):
    name = "presliding_friction"
    listed = 110
    unit = "m"
    form = "the seal's pre-sliding travel (the plant's Dahl law, stepped with the frame)"
    guess = 1e-05
    hi = 0.001
    forms = {"jenkins": "friction builds linearly over VALUE of travel, then slides (elasto-plastic)",
             "iwan": "four elasto-plastic elements of 0.25, 0.75, 1.25 and 1.75 VALUE in parallel"}
    stage = 20

    def start(self, pl):
        if self.variant is None:  # the plant's own Dahl friction over VALUE
            pl.stepper.x_stick = float(self.value or pl.damper.friction.x_stick)
        # the other forms build on the stepper's friction in the load path
        self.z, self.x = [0.0] * len(IWAN), pl.x_act  # the elements' states [-] and where [m]

    def load(self, pl, s):
        if self.value and self.variant:
            travels = (1.0,) if self.variant == "jenkins" else IWAN
            self.z = elastoplastic(self.z, s.x - self.x, [k * self.value for k in travels])
            self.x = s.x
            s.F += abs(s.F_f) * float(np.mean(self.z)) - s.F_f


def elastoplastic(z, dx, travels):
    """States [-] of elasto-plastic (Jenkins) elements after a travel dx [m]: each follows
    the travel over its own stick travel [m] and slides at +-1."""
    return [min(max(zi + dx / y, -1.0), 1.0) for zi, y in zip(z, travels)]
