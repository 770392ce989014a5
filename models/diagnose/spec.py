"""What is known of an effect, in one place: its parameters (bounds, starts), its force
and where that acts, its derivatives (its tangent), what it depends on, when the recording
resolves it, what kind of thing it is and how it is said. How
the virtual plant hides it is the plant's own knowledge (sim_backend/effects/)."""
from __future__ import annotations

from dataclasses import dataclass

V_EPS = 5e-5  # m/s: a friction's sign is softened over this (the model's velocity is fitted, not measured)

# what an effect may depend on (the JSON's `depends_on`)
VARIABLES = ("time", "displacement", "velocity", "direction", "acceleration", "temperature", "frequency", "aux")
# what kind of thing it is: physics of the damper the catalogue names; the test cell
# (its timing, its interference), not the damper; the baseline's own law reshaped (the
# valve curve), not physics left out; or a term outside the catalogue, read by its form
NATURES = ("physics", "cell", "form", "open")


@dataclass(frozen=True)
class P:
    name: str
    x0: float
    lo: float
    hi: float
    unit: str = ""
    grid: tuple = ()  # start values tried first (a parameter whose effect is piecewise)
    # the least value physics allows (a mass, a gas force: 0) where the range reaches below it
    # to take up what else the recording holds (a load cell's offset, a source's inertia
    # compensation); a value fitted below it is no measurement (models/diagnose undetermined)
    floor: float | None = None


@dataclass(frozen=True)
class Effect:
    """An effect the baseline may have left out."""
    name: str
    what: str  # the physics, in an engineer's words
    params: callable  # (d, effect id) -> [P]
    estimate: str | None  # the parameter that sizes the effect (what `dyno prove` reports); None: a basis
    apply: callable  # (model, d, values, Forces, effect id): its force, in place
    acts_on: str  # "motion" (before the baseline), "parts" (its damping, gas or friction) or "total"
    needs: str = ""  # "T" or "aux": a channel it needs; "aux?": tried alone and with each aux channel; "tone": a
    # tone; "frequencies": sine segments of two frequencies or more; "referee": never a candidate, the stand-in a
    # mechanism must beat (loop_surface); "baseline": never a candidate, fitted with the baseline from the start
    # (the cell's timing)
    depends_on: tuple = ()  # of VARIABLES
    nature: str = "physics"  # of NATURES
    say: tuple = ()  # (sentence, parameter shown, factor, unit): see models/diagnose/words.py
    linear: bool = False  # a smooth basis, linear in its coefficients: screened by one Gauss-Newton step
    # (Damper) -> bool: a damper description that has this physics (models/damper.py); the
    # minimal baseline leaving it out is then no fault of that damper
    described: callable = None
    supersedes: str = ""  # an effect this one takes the place of in a model (a lag beyond the alignment)
    # the flexible model with no mechanism in it this effect must beat before it is named;
    # "": the loop's surface when the loop shows all it depends on, else none
    # (models/diagnose/__init__.py referee)
    referee: str = ""
    # (model, data, values, Forces, effect id, columns, the parts before it acted) -> None: the
    # force's derivatives carried through it, in place ({part: {parameter: [N per unit]}}),
    # its own parameters' added; None: what it changes is left to finite differences
    tangent: callable = None
    # (data, its values, their 95 % intervals) -> whether the recording resolves its size; None: always
    resolved: callable = None
    # where it acts among the others, whatever order they were accepted in: the motion's
    # timing first, multiplications of one part, the total's sum, then its caps, the free
    # play's zero-force crossings and last what the load cell does to all of it
    order: int = 0
    short: str = ""  # its name in a list of findings; "": the id's words
    # (step, sample period [s]) -> its sentence from the finding's values and intervals
    # (parameters, ci, effect id), or None for the general one (models/diagnose/words.py)
    words: callable = None
