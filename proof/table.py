"""What `dyno prove` counts (proof/on_plant.py runs it): one run's `Outcome`, each paired
with the null of its seed, noise and rate; the `Row` per effect, form and size of many;
`OpenRow` per seed of `--open`; and the table as text and as the stamped Markdown page."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim_backend.effects import HIDDEN, scaled

GROUP = 3  # a rival group larger than this tells the engineer too little to count as found


def key(effect, form=None):
    """An effect's key in plain.toml's [prove.concealed]: EFFECT, or EFFECT:FORM."""
    return f"{effect}:{form}" if form else effect


@dataclass
class Outcome:
    """One prove run, recorded and diagnosed. What the caller needs travels back with it:
    the workers share no disk."""
    effect: str | None  # hidden: EFFECT or EFFECT+EFFECT; None for a null
    form: str | None
    size: float  # the concealed value's multiple
    noise: float  # every sensor's noise's multiple
    rate: float  # Hz
    seed: int
    rounds: list  # discover's rounds as dicts (a budget given), else []
    added_s: float  # rig time of the next tests [s]
    first_opening: str | None  # what the prove plan alone named first
    accepted: list  # the diagnosis's accepted effects
    claims: list  # of those, the physics (no timing offset or valve form)
    first: str | None  # the first finding that counts
    group: list  # it and what the recording cannot tell from it
    noise_sd: float  # N
    found: list  # each step kept: effect, nature, depends_on, region, size, relevance...
    within_noise: bool  # the final model's held-out error within the noise
    rmse: tuple  # held-out RMSE before and after [N]
    extra_left_out: bool  # beside the hidden effect(s), another said as left out
    extra_compensating: bool  # ... or as may be compensating an earlier one
    force_t: np.ndarray  # s
    force: np.ndarray  # N
    measured: np.ndarray  # bool: in the prove plan's measured segments
    estimate: float | None  # an accepted single effect's own estimate
    before: float  # held-out NRMSE of the baseline
    after: float  # ... and of the final model
    contribution: float | None = None  # N RMS against its null (paired)


@dataclass
class Row:
    """The runs of one (effect, form, size, noise, rate); shares are over its runs, None
    where they do not apply (a pair's opening, a null's detection)."""
    effect: str
    form: str | None
    size: float
    noise: float
    rate_hz: float
    n: int
    value: float | None  # the hidden VALUE
    detection_opening: float | None
    added_s: float
    detection_group: float | None  # named first, or in a group of at most GROUP holding it
    detection: float | None
    wrong_effect: float | None
    false_positive: float | None
    extra_left_out: float | None
    extra_compensating: float | None
    heldout_before: float
    heldout_after: float
    estimate: float | None  # median
    contribution_rms: float | None  # N, median


@dataclass
class OpenRow:
    """One seed of `dyno prove --open`: the hidden force's size against its null, what the
    null claimed, what was found, and the share of the held-out error above the noise the
    final model explains."""
    seed: int
    contribution_rms: float
    null_claims: list
    found: list
    explained: float
    within_noise: bool


def measured_rms_diff(a: Outcome, b: Outcome) -> float:
    """RMS [N] of the force difference of two runs over a's measured samples."""
    _, ia, ib = np.intersect1d(np.round(a.force_t, 6), np.round(b.force_t, 6), return_indices=True)
    return float(np.sqrt(np.mean((a.force[ia] - b.force[ib])[a.measured[ia]] ** 2)))


def paired(results: list[Outcome]) -> list[Outcome]:
    """Each run with a hidden effect gets its contribution: against the null of the same
    seed, noise and rate."""
    nulls = {(r.seed, r.noise, r.rate): r for r in results if r.effect is None}
    for r in results:
        if r.effect:
            r.contribution = measured_rms_diff(r, nulls[r.seed, r.noise, r.rate])
    return results


def _share(flags):
    return float(np.mean(flags))


def _median(values):
    values = [v for v in values if v is not None]
    return float(np.median(values)) if values else None


def table(results: list[Outcome], effects, concealed) -> list[Row]:
    """A row per (effect, form, size, noise, rate) of the paired runs."""
    out = []
    row_key = (lambda r: (r.effect or "null", r.form, r.size, r.noise, r.rate))
    keys = sorted({row_key(r) for r in results}, key=lambda k: ([*effects, "null"].index(k[0]), k[1] or "", *k[2:]))
    for e, form, size, noise, rate in keys:
        rs = [r for r in results if row_key(r) == (e, form, size, noise, rate)]
        parts = set(e.split("+"))
        named = [{a.split(":")[0] for a in r.accepted} for r in rs]
        single, null = e in HIDDEN, e == "null"
        out.append(Row(
            effect=e, form=form or (None if null else "default"), size=size, noise=noise, rate_hz=rate, n=len(rs),
            value=scaled(e, concealed[key(e, form)], size * noise) if key(e, form) in concealed else None,
            detection_opening=_share([r.first_opening == e for r in rs]) if single else None,
            added_s=float(np.median([r.added_s for r in rs])),
            detection_group=(_share([r.first == e or (e in r.group and len(r.group) <= GROUP) for r in rs])
                             if single else None),
            # a single effect: the first accepted; a pair: both accepted, in either order
            detection=(_share([r.first == e for r in rs]) if single
                       else None if null else _share([parts <= n for n in named])),
            wrong_effect=(_share([r.first not in (None, e) for r in rs]) if single
                          else None if null else _share([bool(n - parts) for n in named])),
            false_positive=_share([bool(r.claims) for r in rs]) if null else None,
            extra_left_out=None if null else _share([r.extra_left_out for r in rs]),
            extra_compensating=None if null else _share([r.extra_compensating for r in rs]),
            heldout_before=float(np.median([r.before for r in rs])),
            heldout_after=float(np.median([r.after for r in rs])),
            estimate=_median([r.estimate for r in rs]), contribution_rms=_median([r.contribution for r in rs])))
    return out


def open_rows(results: list[Outcome]) -> list[OpenRow]:
    """Per seed, of open_tasks' results (a null, then the user's physics): OpenRow."""
    rows = []
    for null, r in zip(results[::2], results[1::2]):
        base, final = (e ** 2 for e in r.rmse)
        explained = 1.0 - max(final - r.noise_sd ** 2, 0.0) / max(base - r.noise_sd ** 2, 1e-12)
        rows.append(OpenRow(r.seed, measured_rms_diff(r, null), null.claims, r.found, explained, r.within_noise))
    return rows


# --- the table, as `dyno prove` prints it ---------------------------------------------
HEADER = ("effect", "form", "size", "noise", "rate [Hz]", "hidden value", "force contribution RMS [N]", "detection",
          "named first or in a group of <= 3", "wrong effect", "false positive",
          "also named: left out / may compensate", "estimate (median)", "held-out NRMSE before / after [%]")
ADAPTIVE = ("detection by the prove plan alone", "rig time added [s] (median)")


def _cells(r: Row):
    f = (lambda v, fmt: format(v, fmt) if v is not None else "-")
    return (r.effect, f(r.form, "s"), f"x{r.size:g}", f"x{r.noise:g}", f"{r.rate_hz:g}",
            f(r.value, ".3g"), f(r.contribution_rms, ".2f"), f(r.detection, ".0%"),
            f(r.detection_group, ".0%"), f(r.wrong_effect, ".0%"), f(r.false_positive, ".0%"),
            f"{f(r.extra_left_out, '.0%')} / {f(r.extra_compensating, '.0%')}", f(r.estimate, ".3g"),
            f"{100 * r.heldout_before:.4f} / {100 * r.heldout_after:.4f}")


def rows(table: list[Row], adaptive=False):
    """(header, rows of text) of table(); adaptive: the opening's detection and the next
    tests' rig time beside the detection."""
    header, cells = HEADER, [_cells(r) for r in table]
    if adaptive:
        header = (*HEADER[:7], ADAPTIVE[0], HEADER[7], ADAPTIVE[1], *HEADER[8:])
        cells = [(*c[:7], "-" if r.detection_opening is None else f"{r.detection_opening:.0%}", c[7],
                  f"{r.added_s:.0f}", *c[8:]) for c, r in zip(cells, table)]
    return header, cells


def markdown(header, cells, table, seeds, noise, budget=None, beyond=()):
    """The stamped Markdown page of the table (docs/results), with the plant's forms used;
    budget: the next tests' rig time [s] (--adaptive), None without; beyond: [(row, why)]
    left out, the plant cannot take them."""
    from sim_backend.effects import FORMS
    from protocols.discover import MAX_ROUNDS
    from views.reports import markdown as md
    order = list(HIDDEN)
    used = sorted({(r.effect, r.form) for r in table if r.form not in (None, "default")},
                  key=lambda k: (order.index(k[0]) if k[0] in HIDDEN else 99, k[1]))
    forms = [(e, "default", HIDDEN[e].form) for e in dict.fromkeys(e for e, _ in used) if e in HIDDEN]
    forms += [(e, f, FORMS[f"{e}:{f}"]) for e, f in used if f"{e}:{f}" in FORMS]
    body = md.table(header, cells)
    if beyond:
        body += "\n\nNot run, beyond the plant's range: " + "; ".join(f"{r} ({w})" for r, w in beyond) + "."
    if forms:
        body += "\n\nThe forms (sim_backend/effects/):\n\n" + md.table(
            ("effect", "form", "in the plant"), sorted(forms, key=lambda r: (order.index(r[0]), r[1] != "default", r[1])))
    return md.document("Proof of the diagnosis (dyno prove)", body,
                       f"{seeds} seeds per row on the plain cell through the wires"
                       + (f", each recording followed by the dyno's own next tests (dyno run discover, at most "
                          f"{budget:g} s of rig time added, at most {MAX_ROUNDS} rounds)" if budget is not None else "")
                       + f"; force noise {noise:g} N RMS at noise x1 (every sensor's noise times the noise column). "
                       f"Size x1 is the concealed value at that noise (its contribution equals the force noise, each "
                       f"form calibrated on its own); x10 ten times as strong (a bulk modulus divided by ten, a "
                       f"breakaway ratio's excess times ten); forms: sim_backend/effects/ FORMS. Goals: detection >= "
                       f"90 %, false positives <= 5 %. Method: docs/diagnosis.md.")
