"""What the held-out blocks can tell apart (issue 44): the round's winner, the candidates
it cannot be told from (its rivals) and the flexible model with no mechanism in it that it
must beat before it is named (its referee)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.diagnose.bootstrap import ALPHA
from models.diagnose.candidates import EFFECTS, Model
from models.diagnose.data import Data
from models.diagnose.fitting import linear_fit, open_params
from models.diagnose.result import Candidate, Tried
from models.diagnose.spec import ActsOn, Effect, Nature, Needs, Variable
from models.diagnose.stability import EDGE, Judge, against, holds

RELEVANCE = 0.1  # noise variances an accepted effect must gain at least
# a mechanism whose variables the loop shows is named only when it beats this stand-in
LOOP_VARIABLES = {Variable.DISPLACEMENT, Variable.VELOCITY, Variable.DIRECTION, Variable.ACCELERATION,
                  Variable.FREQUENCY}
STAND_IN = next(n for n, e in EFFECTS.items() if e.needs == Needs.REFEREE and set(e.depends_on) <= LOOP_VARIABLES)
# the cell's timing a round may accept (beyond the alignment fitted with the baseline), a rival
# of a loop mechanism at one frequency
TIMING = next(n for n, e in EFFECTS.items() if e.acts_on == ActsOn.MOTION and e.needs != Needs.BASELINE)
# a lag accepted in some judgements explaining at least this share of what a loop mechanism explains, at one
# frequency, is among its rivals whatever the blocks say: a lag F(t - tau) ~ F - tau dF/dt
# opens the loop at one frequency as a stiffness, a compressible oil or a hysteresis does,
# and a term along the stroke per direction takes up any loop of one amplitude and
# frequency, a lag's with the file's own misfit (a 17 ms lag on a real 0.5 Hz run: 0.22)
TIMING_SHARE = 0.1
MECHANISMS = (Nature.PHYSICS, Nature.OPEN)  # natures that say physics left out: sized, and faced with a referee
ONE_FREQUENCY = 1.1  # segments whose frequencies are within this ratio are one test frequency


def bar(tried: int) -> float:
    """The p-value each of a round's `tried` candidates must beat: ALPHA, Bonferroni-corrected."""
    return ALPHA / max(tried, 1)


def not_proven(candidates: list[Candidate]) -> tuple[int, list[Candidate]]:
    """(tried, [Candidate]): the last round's candidates that lower the held-out error and
    pass one paired test (p < ALPHA) but not the bar for the `tried` of the round: the
    recording cannot tell whether any of them is real. Lowest held-out error first."""
    if not candidates:
        return 0, []
    last = [c for c in candidates if c.round == max(c.round for c in candidates)]
    near = [c for c in last if bar(len(last)) <= c.p_value < ALPHA and c.relevance >= RELEVANCE]
    return len(last), sorted(near, key=lambda c: c.nrmse_heldout)


def term(e: str) -> bool:
    """Is e a term outside the catalogue (or the baseline's form reshaped), not a named effect?"""
    return EFFECTS[e.split(":")[0]].nature in (Nature.OPEN, Nature.FORM)



def _first(ok, near, order, judge):
    """The one the model carries: of ok's candidate with the largest gain and those of
    `near` (candidates accepted in more than stability.EDGE of the judgements) the held-out
    blocks cannot tell from it (its rivals in most judgements), the earliest in `order` (the
    catalogue's). Which of equals has the larger gain, or is accepted in one judgement more,
    is the last bits' choice; the order is the same on every machine, and so is the path the
    rounds after it take."""
    top = max(ok, key=lambda x: x.candidate.gain)
    equal = [top] + [x for x in near if x is not top and 1.0 - judge.share(top.residual, x.residual, ALPHA) > 0.5]
    return min(equal, key=lambda x: order.index(x.candidate.effect))


def chosen(ok: list[Tried], near: list[Tried], judge: Judge, alpha: float, order: list[str]) -> Tried:
    """The accepted round's winner: the largest gain or one it cannot be told from (_first),
    except that a term outside the catalogue must beat the best catalogue effect by the bar
    any effect must pass: by RELEVANCE noise variances more, significantly (the catalogue's
    test, block by block on the held-out cycles, in at least half of the judgements). Where
    it does not, the named effect is the better account of the same residual (fewer
    parameters, each with a physical reading)."""
    best = _first(ok, near, order, judge)
    named = [x for x in ok if not term(x.candidate.effect)]
    if not term(best.candidate.effect) or not named:
        return best
    cat = _first(named, [x for x in near if not term(x.candidate.effect)], order, judge)
    better = (judge.share(best.residual, cat.residual, alpha)
              * against(best.candidate.relevance - cat.candidate.relevance, RELEVANCE) >= 0.5)
    return best if better else cat


def rivals_of(d: Data, best: Candidate, r_best: np.ndarray, round_: list[Tried], judge: Judge
              ) -> tuple[list[tuple[str, float, float]], dict[str, np.ndarray]]:
    """(rivals, {candidate: its votes as a rival}) of a round's winner: the candidates the
    held-out blocks cannot tell from it (rivals), and the cell's timing where one test
    frequency cannot (timing_rival). Its stand-in is stood_in's."""
    found, votes = rivals(best, r_best, round_, judge)
    lag = timing_rival(d, best, r_best, [x for x in round_ if x.candidate.accept_share > EDGE], judge, found)
    if lag:
        found, votes = sorted(found + [lag], key=lambda x: -x[1]), {**votes, lag[0]: np.asarray(best.accept_votes, float)}
    return found, votes


def timing_rival(d: Data, best: Candidate, r_best: np.ndarray, near: list[Tried], judge: Judge,
                 found: list[tuple[str, float, float]]) -> tuple[str, float, float] | None:
    """(the cell's timing, its gain, paired p) when it is a rival of the winner by physics,
    or None: at one test frequency a lag and a mechanism of the loop (one whose variables
    the loop shows, other than the timing itself) open the loop alike, so a lag that
    explains TIMING_SHARE of what the winner explains stays a candidate: another frequency
    tells them apart (a lag's phase grows with it, a mechanism's does not). near: the
    round's candidates accepted in more than stability.EDGE of the judgements."""
    f = [f for _, f in d.segments if f]
    spec = EFFECTS[best.effect.split(":")[0]]
    if (not f or max(f) > ONE_FREQUENCY * min(f) or spec.name == TIMING or spec.nature not in MECHANISMS
            or not set(spec.depends_on) <= LOOP_VARIABLES or any(e == TIMING for e, _, _ in found)):
        return None
    lag = next((x for x in near if x.candidate.effect == TIMING), None)
    if lag is None or not lag.candidate.gain >= TIMING_SHARE * best.gain:
        return None
    return TIMING, lag.candidate.relevance, judge.p(r_best, lag.residual, ALPHA)


def referee(spec: Effect) -> str | None:
    """The flexible model with no mechanism in it that an effect must beat before it is
    named: its own (a temperature's effect faces the same shape in time: while the
    temperature only rises, the recording cannot tell it from time), else the loop's surface
    when the loop shows every variable it depends on, else none (a channel (aux) or a tone
    is evidence the surface cannot have)."""
    if spec.referee:
        return spec.referee
    return STAND_IN if set(spec.depends_on) <= LOOP_VARIABLES else None


@dataclass
class Refereed:
    """A round's winner against its referee: the term it faced ("": none), the stand-in
    when that explained as much ((term, paired p), else None) and, per judgement, 1.0
    where it did."""
    faced: str
    stand_in: tuple | None
    votes: np.ndarray


def stood_in(d: Data, base, fitted: list[str], best: Candidate, b_folds: list, r_best: np.ndarray, folds: list,
             judge: Judge, rival_votes: dict[str, np.ndarray] | None = None) -> Refereed:
    """Refereed: the stand-in when a mechanism does not beat,
    on the same held-out blocks at p < ALPHA in at least half of the judgements, its referee
    (above) fitted beside the same accepted effects; votes: 1.0 in each judgement in which it
    does not. Catalogue physics and terms outside it alike, so that the answer cannot slide from
    one flexible name to the next. The cell's timing or a form carried where the recording
    cannot tell it from physics (a rival in at least stability.HELD of the judgements,
    rival_votes) faces that physics' referee: which of equals the model carried is not to
    decide whether the mechanism was told from the surface (the UTFSM 2 mm 5 Hz 1 A file: a
    friction carried, a stand-in; the cell's timing carried, with the same rivals, a group)."""
    spec = EFFECTS[best.effect.split(":")[0]]
    if spec.nature not in MECHANISMS:
        spec = next((EFFECTS[e.split(":")[0]] for e, v in (rival_votes or {}).items()
                     if EFFECTS[e.split(":")[0]].nature in MECHANISMS and holds(np.mean(v))), spec)
    judge_term = referee(spec)
    if spec.nature not in MECHANISMS or ":" in best.effect or not judge_term or judge_term in fitted:
        return Refereed("", None, np.zeros(len(judge.variants)))
    m = Model(d, fitted + [judge_term], base)
    # from the winner's own fit (the baseline where the mechanism's nonlinear refit moved it),
    # so that the two differ by what each adds, not by how far the baseline's refit went
    r = linear_fit(m, d, folds, b_folds, hold=open_params(d, fitted))[2]
    votes = 1.0 - judge.votes(r_best, r, ALPHA)
    return Refereed(judge_term, (judge_term, judge.p(r_best, r, ALPHA)) if np.mean(votes) >= 0.5 else None, votes)


def rivals(best: Candidate, r_best: np.ndarray, round_: list[Tried], judge: Judge
           ) -> tuple[list[tuple[str, float, float]], dict[str, np.ndarray]]:
    """([(effect, gain in noise variances, paired p)], {effect: votes}) of the round's
    candidates the recording cannot tell from the winner: on the same held-out blocks, the
    log ratio of the candidate's error to the winner's, bootstrapped; p >= ALPHA: the winner
    is not better (a paired test, not two p-values against the baseline compared). A
    candidate is a rival in a judgement where both are accepted and the winner is not better
    (votes: 1.0 in each; an acceptance within a bar's band counts half), one judgement at a
    time: gated on its acceptance share instead, a candidate accepted in 7 of 15 judgements
    was no rival at all and in 8 a rival in all 15, a flip by one vote; and a winner carried
    at the edge of its own acceptance (one the blocks cannot tell from the best) held its
    group firmly. Said when a rival in more than stability.EDGE of the judgements (below
    stability.HELD at the edge). Another form of the winner's own effect is not a rival: it
    is the same physics."""
    out, votes = [], {}
    for c, r in ((x.candidate, x.residual) for x in round_):
        if c.effect.split(":")[0] == best.effect.split(":")[0] or not np.any(c.accept_votes):
            continue
        # both accepted: the lesser of the two (two acceptances within a bar's band are at
        # its edge together, a half, not a quarter)
        both = np.minimum(best.accept_votes, c.accept_votes)
        votes[c.effect] = both * (1.0 - judge.votes(r_best, r, ALPHA))
        if np.mean(votes[c.effect]) > EDGE:  # a rival in some judgements: said, with its share
            out.append((c.effect, c.relevance, judge.p(r_best, r, ALPHA)))
    return sorted(out, key=lambda x: -x[1]), votes
