"""What is known of an effect, in one place: its parameters (bounds, starts), its force
and where that acts, its derivatives (its tangent), what it depends on, when the recording
resolves it, what kind of thing it is and how it is said. How
the virtual plant hides it is the plant's own knowledge (sim_backend/effects/)."""
from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

V_EPS = 5e-5  # m/s: a friction's sign is softened over this (the model's velocity is fitted, not measured)


# An effect's kinds are closed sets: a misspelt one fails when its module is imported (Effect
# checks them), not as an effect silently refereed as another. Each is a str, so the JSON,
# the words and a comparison with its text read it unchanged.
class Variable(StrEnum):
    """What an effect may depend on (the JSON's `depends_on`)."""
    TIME = "time"
    DISPLACEMENT = "displacement"
    VELOCITY = "velocity"
    DIRECTION = "direction"
    ACCELERATION = "acceleration"
    TEMPERATURE = "temperature"
    FREQUENCY = "frequency"
    AUX = "aux"


class Nature(StrEnum):
    """What kind of thing an effect is."""
    PHYSICS = "physics"  # physics of the damper the catalogue names
    CELL = "cell"  # the test cell (its timing, its interference), not the damper
    FORM = "form"  # the baseline's own law reshaped (the valve curve), not physics left out
    OPEN = "open"  # a term outside the catalogue, read by its form


class ActsOn(StrEnum):
    """Where an effect's force acts (its `apply`)."""
    MOTION = "motion"  # before the baseline: the motion it sees
    PARTS = "parts"  # the baseline's damping, gas or friction
    TOTAL = "total"  # the total force


class Needs(StrEnum):
    """What an effect needs of the recording before it is a candidate."""
    NOTHING = ""
    TEMPERATURE = "T"  # a temperature channel
    AUX = "aux"  # an aux channel
    AUX_OR_NOT = "aux?"  # tried alone and with each aux channel
    TONE = "tone"  # a tone in the residual
    FREQUENCIES = "frequencies"  # sine segments of two frequencies or more
    REFEREE = "referee"  # never a candidate: the stand-in a mechanism must beat (loop_surface)
    BASELINE = "baseline"  # never a candidate: fitted with the baseline from the start (the cell's timing)


VARIABLES = tuple(Variable)
NATURES = tuple(Nature)


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
    acts_on: ActsOn
    needs: Needs = Needs.NOTHING
    depends_on: tuple = ()  # of Variable
    nature: Nature = Nature.PHYSICS
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
    # its place in the catalogue: the order the rounds try the candidates in, and which of two
    # the held-out blocks cannot tell apart the model carries (referees._first); the plant
    # lists its own version at the same place (sim_backend/effects/base.py Hidden.listed)
    listed: int = 0
    short: str = ""  # its name in a list of findings; "": the id's words
    # (step, sample period [s]) -> its sentence from the finding's values and intervals
    # (parameters, ci, effect id), or None for the general one (models/diagnose/words.py)
    words: callable = None

    def __post_init__(self):
        """Each kind checked and made its enum: a typo is a ValueError naming the effect."""
        try:
            for field, kind in (("acts_on", ActsOn), ("needs", Needs), ("nature", Nature)):
                object.__setattr__(self, field, kind(getattr(self, field)))
            object.__setattr__(self, "depends_on", tuple(Variable(v) for v in self.depends_on))
        except ValueError as e:
            raise ValueError(f"effect {self.name!r}: {e}") from None
