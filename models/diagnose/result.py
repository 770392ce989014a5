"""What `diagnose` returns, typed: the baseline, every candidate tried, the effects
accepted in order (with what each is, where it lives and how big), what is left over, and
the final model. Forces in N, errors as fractions of the force range unless named _n."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models.diagnose.data import Data
from models.diagnose.spec import ActsOn


@dataclass
class CellFit:
    """An effect of the test cell fitted with the baseline (its timing), not a candidate."""
    effect: str
    parameters: dict
    ci: dict  # {name: [lo, hi]}, 95 %
    resolved: bool  # the recording resolves it (models.diagnose.resolved)


@dataclass
class Baseline:
    name: str
    parameters: dict
    sd: dict
    nrmse_train: float
    nrmse_heldout: float
    rmse_heldout: float  # N
    r2_heldout: float
    residual: np.ndarray  # N, model - measured; held-out samples from a fit that never saw them
    model_gas_force: float | None  # N: a damper model's gas force at the mean position, as simulated
    cell: list = field(default_factory=list)  # [CellFit]: the cell's effects fitted with it
    stopped: int = 0  # folds whose fit stopped at its step limit before converging (fitting.FTOL)


@dataclass
class Candidate:
    """One effect or term tried in one round."""
    effect: str
    round: int
    parameters: dict  # its own
    ci: dict  # {name: [lo, hi]}, 95 %
    nrmse_heldout: float
    rmse_heldout: float
    r2_heldout: float
    p_value: float
    gain: float  # held-out mean-square improvement [N^2]
    relevance: float  # gain in force-noise variances
    # in each held-out judgement (models/diagnose/stability.py), whether it passes the
    # acceptance test: significant, worth having (0.5 within the band of a fixed bar), resolved
    accept_votes: np.ndarray = field(default_factory=lambda: np.zeros(1))
    screen: float = float("nan")  # the screen's held-out gain [noise variances] (screen.py); nan: not screened
    screened: bool = False  # ruled out by the screen, not fitted: its gain and relevance are the screen's

    @property
    def accept_share(self) -> float:
        """The share of the judgements in which it is accepted; accepted at 0.5 and above."""
        return float(np.mean(self.accept_votes))


@dataclass
class Tried:
    """A round's candidate as fitted beside the effects so far and judged on the held-out
    blocks."""
    candidate: Candidate
    values: dict  # pooled over the folds
    folds: list  # values per fold
    residual: np.ndarray  # N


@dataclass
class Step:
    """An accepted effect or term, in the order accepted."""
    effect: str
    before: float  # held-out NRMSE before it
    after: float
    parameters: dict
    ci: dict
    p_value: float
    residual_before: np.ndarray  # N
    residual_after: np.ndarray  # N
    trades_with: list  # [(earlier effect, |correlation|)]
    form_of: list  # [(earlier effect, share of the gain a change in its form also brings)]
    compensates: list  # earlier effects whose form this one may be compensating
    replaced_by: str | None = None  # a term outside the catalogue that explains it as well
    # the round's other candidates the held-out blocks cannot tell from it:
    # [(effect, gain in noise variances, paired p that this one is better)], largest gain first
    rivals: list = field(default_factory=list)
    # its practical size when accepted: held-out gain in force-noise variances, and the share
    # of the held-out mean-square error above the noise it took away
    relevance: float = float("nan")
    excess_share: float = float("nan")
    small: bool = False  # significant but below the practical size: kept in the model, not named (named())
    # (stand-in, paired p) when a flexible surface with no mechanism explains as much: not named
    stand_in: tuple | None = None
    referee: str = ""  # the flexible model with no mechanism it faced before it was named ("": none)
    # what it is (describe): spec.NATURES, spec.VARIABLES, where it lives, elastic or dissipative, size
    nature: str = ""
    depends_on: list = field(default_factory=list)
    region: str = ""
    character: str = ""
    size_rms_n: float = float("nan")
    size_peak_n: float = float("nan")
    tone_hz: float | None = None
    # how firmly it holds (stability.py): the share of the held-out judgements in which it is
    # accepted, each rival's share of being one (rivals holds those at 0.5 and above), the
    # share in which a stand-in explains as much, and in which it is named (held_in)
    accept_votes: np.ndarray = field(default_factory=lambda: np.ones(1))
    rival_votes: dict = field(default_factory=dict)  # {candidate: per judgement, 1.0 where it is a rival}
    stand_in_votes: np.ndarray = field(default_factory=lambda: np.zeros(1))
    held_in: float = 1.0

    @property
    def accept_share(self) -> float:
        return float(np.mean(self.accept_votes))

    @property
    def rival_shares(self) -> dict:
        return {e: float(np.mean(v)) for e, v in self.rival_votes.items()}

    @property
    def stand_in_share(self) -> float:
        return float(np.mean(self.stand_in_votes))


@dataclass
class LeftOver:
    """Whether the final held-out residual is within the noise (in at least half of the
    held-out judgements; within_share of them)."""
    p_value: float
    above_noise_rms_n: float
    within_noise: bool
    within_share: float = 1.0


@dataclass
class Final:
    nrmse_heldout: float
    rmse_heldout: float  # N
    r2_heldout: float
    parameters: dict
    force: np.ndarray  # N, the final model's prediction on every sample


@dataclass
class Diagnosis:
    data: Data
    holdout: str | float  # "interleaved" or the tail's fraction
    held_out: np.ndarray  # samples judged or reported on
    reported: np.ndarray  # samples the held-out measures are reported on
    baseline: Baseline
    noise_sd: float  # N
    locations: list  # [{where, energy_share, sample_share, mean_residual, concentration}] of the baseline residual
    remaining: list  # the same, of the final residual
    candidates: list  # [Candidate]
    accepted: list  # effect ids, in order, after any replacement
    steps: list  # [Step]
    not_assessed: list  # effects that could not be tried, and why
    left_over: LeftOver
    final: Final
    noise_from: str = ""  # where the noise estimate came from, in words (noise_from())
    described: dict = field(default_factory=dict)  # {effect: damper}: physics the recording's own damper has
    # [(test, [segment names], [force range, N])]: a test run again with something the
    # recording does not carry changed (records.data.differing_repeats)
    repeats: list = field(default_factory=list)
    judge: object = None  # the held-out judgements every decision was taken on (stability.Judge)
    timing: dict = field(default_factory=dict)  # where its time went (models/diagnose/stages.py Clock.report)

    def effects(self):
        """The final model's effects: the cell's, fitted with the baseline, then those accepted."""
        return [c.effect for c in self.baseline.cell] + self.accepted

    def cell_found(self):
        """The cell's effects the recording resolves (its timing, said with the baseline)."""
        return [c.effect for c in self.baseline.cell if c.resolved]

    def named(self):
        """The accepted effects said by name: not dropped again, and named (not small, not
        said as a rival group or as what a flexible stand-in explains as well) in at least
        stability.HELD of the held-out judgements."""
        from models.diagnose.stability import holds
        return [s.effect for s in self.steps if not s.replaced_by and holds(s.held_in)]

    def channel_timing(self) -> tuple[float, object]:
        """The recording's one timing figure, which diagnose, the report and prove --on all
        say: (the shift [s] of the motion the final model's force answers, negative where the
        force reading lags the displacement; its fit: a sensor delay's Step accepted and not
        dropped, else the channels' alignment's CellFit, else None)."""
        from models.diagnose.candidates import EFFECTS
        for fit in [s for s in self.steps if not s.replaced_by] + list(self.baseline.cell):
            spec = EFFECTS.get(fit.effect.split(":")[0])
            if spec is not None and spec.acts_on == ActsOn.MOTION and spec.estimate in fit.parameters:
                return float(fit.parameters[spec.estimate]), fit
        return 0.0, None

    def at_edge(self):
        """The accepted effects named in some of the held-out judgements but fewer than
        stability.HELD: said as at the edge, with their share, never as a name."""
        from models.diagnose.stability import at_edge
        return [s.effect for s in self.steps if not s.replaced_by and at_edge(s.held_in)]
