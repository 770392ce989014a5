"""What every hidden effect of the virtual plant is: what its VALUE means, the forms it
comes in, and its physics with its own state, reached by the plant at the few points
where physics can hide (each a method that does nothing unless the effect acts there).
Like a driver that owns its state: the plant holds the effects, never their insides."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar


class Hidden:
    # --- what VALUE is (`dyno run --effect NAME[:FORM]=VALUE`, `dyno prove`) -------------
    name: ClassVar[str]
    unit: ClassVar[str]  # of VALUE
    form: ClassVar[str]  # what VALUE sets in the default form
    guess: ClassVar[float]  # a VALUE of about noise size: where `dyno prove --calibrate` starts
    grows: ClassVar[str] = "in proportion"  # how VALUE makes it s times as strong: "in proportion"
    # (VALUE s), "inversely" (VALUE / s, a bulk modulus), "in its excess over 1" (1 + (VALUE - 1) s)
    forms: ClassVar[dict] = {}  # {other form: what VALUE sets in it}
    lo: ClassVar[float] = 0.0  # VALUE's range: what a damper or cell could have; beyond it,
    hi: ClassVar[float] = math.inf  # a typing mistake
    weakest: ClassVar[float] = 1e-3  # the weakest strength (times the guess's) calibration tries
    # --- where it acts --------------------------------------------------------------------
    listed: ClassVar[int] = 0  # its place among the effects: the diagnosis's catalogue's (Effect.listed)
    stage: ClassVar[int] = 0  # its place in the load path (lower acts first)
    repack_K: ClassVar[float | None] = None  # K: re-pack the damper model at least this often
    drives: ClassVar[dict] = {}  # {channel: what it is} of the channels it makes drive the damper

    def __init__(self, value: float, form: str | None = None):
        self.value, self.variant = float(value), form  # variant: the form it is in (None: default)

    @classmethod
    def scaled(cls, value, s):
        """The VALUE that makes the effect s times as strong as at `value` (its `grows`)."""
        if cls.grows == "inversely":
            return value / s
        if cls.grows == "in its excess over 1":
            return 1 + (value - 1) * s
        return value * s

    @classmethod
    def without_run(cls, value, t, F0):
        """What the effect adds to the measured force F0 [N] at times t [s], when that
        follows from F0 alone (a lag of the motion readings); None: run the plant."""
        return None

    # --- the plant's hooks, in the order of a run -----------------------------------------
    def describe(self, damper):
        """The damper's description with the effect in it (oil, friction, temperature)."""
        return damper

    def start(self, pl):
        """Its state at the plant's start (the stepper built, nothing stepped)."""

    def rod(self, pl, h, v_prev, x, v):
        """(x [m], v [m/s]) of the damper's rod when the mount moved to x at v over h [s]."""
        return x, v

    def load(self, pl, s):
        """Change the step's forces and pressures s (load_path.Step) [N, Pa]."""

    def warm(self, pl, h):
        """Its thermal state over h [s], the body's temperature already stepped."""

    def gas_temperature(self, pl):
        """The gas charge's temperature [K] if the effect sets it, else None."""
        return None

    def repacked(self, pl):
        """The damper model was re-packed at a new temperature."""

    def advance(self, pl, h):
        """Its state at the end of a step of h [s] (filters, lags)."""

    def read(self, pl, clean):
        """Change the transducers' noise-free readings {force, x, v} [N, m, m/s]."""


@dataclass(slots=True)
class PlantStep:
    """One plant step through the load path, as the hidden effects see and change it."""
    h: float  # s: the step
    x: float  # m: the rod's position
    v: float  # m/s: its mean velocity over the step
    v_prev: float  # m/s: the mount's velocity the step before
    F: float  # N: force on the load cell
    F_d: float  # N: damping
    F_f: float  # N: the seal's friction
    P1: float  # Pa: compression chamber
    P2: float  # Pa: rebound chamber
