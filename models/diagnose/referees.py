"""What the held-out blocks can tell apart (issue 44): the paired block bootstrap, the
round's winner, the candidates it cannot be told from (its rivals) and the flexible model
with no mechanism in it that it must beat before it is named (its referee)."""
from __future__ import annotations

import threading

import numpy as np

from models.diagnose.candidates import EFFECTS, Model
from models.diagnose.fitting import linear_fit, open_params

ALPHA = 0.01  # the bar of every paired test
RELEVANCE = 0.1  # noise variances an accepted effect must gain at least
# a mechanism whose variables the loop shows is named only when it beats this stand-in
STAND_IN = "loop_surface"
LOOP_VARIABLES = {"displacement", "velocity", "direction", "acceleration", "frequency"}
BOOT = 2000
SURE_HITS = 50
MORE = 4  # the most resamples a p-value at the bar draws, in multiples of its usual number


def bar(tried):
    """The p-value each of a round's `tried` candidates must beat: ALPHA, Bonferroni-corrected."""
    return ALPHA / max(tried, 1)


def not_proven(candidates):
    """(tried, [Candidate]): the last round's candidates that lower the held-out error and
    pass one paired test (p < ALPHA) but not the bar for the `tried` of the round: the
    recording cannot tell whether any of them is real. Lowest held-out error first."""
    if not candidates:
        return 0, []
    last = [c for c in candidates if c.round == max(c.round for c in candidates)]
    near = [c for c in last if bar(len(last)) <= c.p_value < ALPHA and c.relevance >= RELEVANCE]
    return len(last), sorted(near, key=lambda c: c.nrmse_heldout)


def block_sse(r, block, ids):
    return np.bincount(block, weights=r ** 2, minlength=ids.max() + 1)[ids]


# the resamples kept in memory, by (blocks, seed, chunk): every test of a diagnosis draws
# the same ones, so a round's dozen candidates cost one draw, not a dozen
_KEPT, _KEPT_BYTES, _kept_lock = {}, 256e6, threading.Lock()


def resamples(n, seed, i):
    """Chunk i of the block bootstrap's resamples of n blocks: BOOT rows, each how often
    each block is drawn (blocks drawn with replacement), from its own seed, so a test gives
    the same p whether the chunk was kept or is drawn again."""
    key = (n, seed, i)
    w = _KEPT.get(key)
    if w is None:
        idx = np.random.default_rng([seed, n, i]).integers(0, n, (BOOT, n)) + n * np.arange(BOOT)[:, None]
        w = np.bincount(idx.ravel(), minlength=BOOT * n).reshape(BOOT, n).astype(np.float32)
        with _kept_lock:
            kept = sum(v.nbytes for v in _KEPT.values())
            # room made from other recordings' chunks (another n or seed) only: every test
            # starts at chunk 0, so a full store keeps its first chunks and draws the rare
            # late ones (a p-value at the bar) again. Evicting the oldest instead evicted
            # chunk 0 first, and every later test then missed: 297 draws of 971 on the crank
            for k in [k for k in _KEPT if k[:2] != key[:2]]:
                if kept + w.nbytes <= _KEPT_BYTES:
                    break
                kept -= _KEPT.pop(k).nbytes
            if kept + w.nbytes <= _KEPT_BYTES:
                _KEPT[key] = w
    return w


def p_value(d_c, seed, alpha=ALPHA):
    """One-sided bootstrap p-value of mean(d_c) > 0 over blocks d_c, with enough resamples
    (at least BOOT, and 20 / alpha) that the smallest p it can give is well under alpha.
    It stops early once p is surely above alpha (SURE_HITS hits, and alpha under p's
    lower bound at 3.3 sd), as for most candidates tried: p is then known to about 15 %.
    Where p is still within 3.3 sd of alpha it draws on, up to MORE times as many
    resamples: a verdict at the bar is the data's, not the draw's. Every test with the
    same seed and number of blocks resamples the same blocks (common random numbers: two
    candidates' p differ by their data, not by their draws)."""
    n = len(d_c)
    if n < 3:
        return 1.0
    m = d_c.mean()
    x = (d_c / n).astype(np.float32)
    total = max(BOOT, int(np.ceil(20 / alpha)))
    hits = done = i = 0
    while done < MORE * total:
        boot = resamples(n, seed, i) @ x
        hits, done, i = hits + int(np.sum(boot - m >= m)), done + BOOT, i + 1
        if hits >= SURE_HITS and hits - 3.3 * np.sqrt(hits) > alpha * done:
            break
        if done >= total and abs(hits - alpha * done) >= 3.3 * np.sqrt(alpha * done):
            break
    return float((hits + 1) / (done + 1))


def term(e):
    """Is e a term outside the catalogue (or the baseline's form reshaped), not a named effect?"""
    return EFFECTS[e.split(":")[0]].nature in ("open", "form")



def chosen(ok, block, judged, judged_blocks, alpha, seed):
    """The accepted round's winner: the largest gain, except that a term outside the
    catalogue must beat the best catalogue effect by the bar any effect must pass: by
    RELEVANCE noise variances more, significantly (the catalogue's test, block by block on
    the held-out cycles). Where it does not, the named effect is the better account of the
    same residual (fewer parameters, each with a physical reading)."""
    best = max(ok, key=lambda x: x[0].gain)
    named = [x for x in ok if not term(x[0].effect)]
    if not term(best[0].effect) or not named:
        return best
    cat = max(named, key=lambda x: x[0].gain)
    sse = [block_sse(np.where(judged, x[3], 0.0), block, judged_blocks) for x in (cat, best)]
    rel = np.log(np.maximum(sse[0], 1e-30) / np.maximum(sse[1], 1e-30))
    better = best[0].relevance - cat[0].relevance >= RELEVANCE and p_value(rel, seed, alpha) < alpha
    return best if better else cat


def referees(d, base, fitted, best, b_folds, r_best, round_, folds, block, judged, judged_blocks, alpha, seed):
    """(rivals, stand-in) of a round's winner: the candidates the held-out blocks cannot
    tell from it, and the flexible stand-in when it explains as much."""
    significant = [x for x in round_ if x[0].p_value < alpha and x[0].relevance >= RELEVANCE]
    found = rivals(best, r_best, significant, block, judged, judged_blocks, seed)
    return found, stood_in(d, base, fitted, best, b_folds, r_best, folds, block, judged, judged_blocks, seed)


def referee(spec):
    """The flexible model with no mechanism in it that an effect must beat before it is
    named: its own (a temperature's effect faces the same shape in time: while the
    temperature only rises, the recording cannot tell it from time), else the loop's surface
    when the loop shows every variable it depends on, else none (a channel (aux) or a tone
    is evidence the surface cannot have)."""
    if spec.referee:
        return spec.referee
    return STAND_IN if set(spec.depends_on) <= LOOP_VARIABLES else None


def stood_in(d, base, fitted, best, b_folds, r_best, folds, block, judged, judged_blocks, seed):
    """(stand-in, paired p) when a mechanism does not beat, on the same held-out blocks at
    p < ALPHA, its referee (above) fitted beside the same accepted effects; else None.
    Catalogue physics and terms outside it alike, so that the answer cannot slide from one
    flexible name to the next."""
    spec = EFFECTS[best.effect.split(":")[0]]
    judge = referee(spec)
    if spec.nature not in ("physics", "open") or ":" in best.effect or not judge or judge in fitted:
        return None
    m = Model(d, fitted + [judge], base)
    # from the winner's own fit (the baseline where the mechanism's nonlinear refit moved it),
    # so that the two differ by what each adds, not by how far the baseline's refit went
    r = linear_fit(m, d, folds, b_folds, hold=open_params(d, fitted))[2]
    rel = np.log(np.maximum(block_sse(np.where(judged, r, 0.0), block, judged_blocks), 1e-30)
                 / np.maximum(block_sse(np.where(judged, r_best, 0.0), block, judged_blocks), 1e-30))
    p = p_value(rel, seed, ALPHA)
    return None if p < ALPHA else (judge, p)


def rivals(best, r_best, significant, block, judged, judged_blocks, seed):
    """[(effect, gain in noise variances, paired p)] of the round's significant candidates
    the recording cannot tell from the winner: on the same held-out blocks, the log ratio of
    the candidate's error to the winner's, bootstrapped; p >= ALPHA: the winner is not
    better (a paired test, not two p-values against the baseline compared). Another form of
    the winner's own effect is not a rival: it is the same physics."""
    sse_best = block_sse(np.where(judged, r_best, 0.0), block, judged_blocks)
    out = []
    for c, _, _, r in significant:
        if c.effect.split(":")[0] == best.effect.split(":")[0]:
            continue
        rel = np.log(np.maximum(block_sse(np.where(judged, r, 0.0), block, judged_blocks), 1e-30)
                     / np.maximum(sse_best, 1e-30))
        p = p_value(rel, seed, ALPHA)
        if p >= ALPHA:
            out.append((c.effect, c.relevance, p))
    return sorted(out, key=lambda x: -x[1])
