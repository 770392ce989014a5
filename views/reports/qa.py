"""Production QA: a run's force at the velocity table's speeds against a reference (another
run, or a damper model along this run's own motion), inside a tolerance band: pass or
fail per speed and direction, with the margin left. SI inside (m/s, N).

Where a run was tested warmer or cooler than its reference run, its forces are moved to the
reference's temperature with the run's identified model (RECORDING.model.json, from
`dyno identify`): each peak gains what the model gives at the reference's temperature less
what it gives at the run's, along the run's own motion (damping, gas force and friction
follow temperature: thesis eqs 3.57-3.62 and 4.17, 3.8-3.16, 3.3). Below COMPENSATE_K
apart nothing is moved."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models.damper import DamperError
from models.minimal import load_reference as load_damper, outside
from records.data import segments, sign_problem
from records import spec_table
from rig.errors import UsageError
from records.reader import load_recording
from views.reports import peaks
from views.reports import velocity_table as vt
from views.reports.plots import plt
from views.reports.page import save
from protocols.units import Units, fmt, parse_with_unit


@dataclass
class Tolerance:
    """The band about the reference: the larger of pct of it and newtons."""
    pct: float = 0.0
    newtons: float = 0.0

    def band(self, ref):
        return np.maximum(np.abs(ref) * self.pct / 100.0, self.newtons)

    def __str__(self):
        parts = ([f"{self.pct:g} %"] if self.pct else []) + ([f"{self.newtons:g} N"] if self.newtons else [])
        return " or ".join(parts)


MAX_TOLERANCE_N = 1e5  # N: a band wider than any damper dyno's load cell passes everything


def parse_tolerance(text: str) -> Tolerance:
    """'5%' (of the reference), '50N' or '11lbf' (any force unit units.toml names), or
    both: '5%,50N' (the larger). A bare number is refused: 5 % and 5 N differ thirtyfold."""
    tol = Tolerance()
    for part in text.replace(" ", "").split(","):
        if part.startswith("-"):  # -0% as well: a band is a size
            raise ValueError(f"--tolerance: {part!r} is negative: a band is a size about the reference (5%, 50N, "
                             f"or 5%,50N)")
        if part.endswith("%"):
            try:
                tol.pct = float(part[:-1])
            except ValueError:
                raise ValueError(f"--tolerance: {text!r} is not like 5% or 50N or 5%,50N") from None
            continue
        try:
            tol.newtons = parse_with_unit("force", part)
        except ValueError as e:
            raise ValueError(f"--tolerance: {e}, or a percentage of the reference (5%)") from None
    if not (0 <= tol.pct <= 100 and 0 <= tol.newtons <= MAX_TOLERANCE_N and (tol.pct > 0 or tol.newtons > 0)):
        raise ValueError(f"--tolerance: {text!r} must be positive: a percentage up to 100, newtons up to "
                         f"{MAX_TOLERANCE_N:g}")
    return tol


def verdict(points: int, failed: int, outside=(), units=Units(), furthest=False) -> str:
    """The one QA sentence (CLI, web, run index): "FAIL: 17 of 18 inside the band; 1 outside:
    rebound at 500 mm/s, -4.1 % (-41 N)" (the force's size against the reference's: -4.1 %
    is weak; the force beside it, since a percentage of a reference near zero says little).
    outside: the failing Verdicts, when known; furthest: name only the one furthest outside
    (a test sheet's line)."""
    head = f"{'FAIL' if failed else 'PASS'}: {points - failed} of {points} inside the band"
    if not failed:
        return head
    if furthest and outside:
        outside = [min(outside, key=lambda v: v.margin_N)]
    where = "; ".join(f"{v.direction} at {fmt(units.show('velocity', v.v_m_s), 3)} {units.unit('velocity')}, "
                      f"{100 * (abs(v.measured_N) / max(abs(v.reference_N), 1e-9) - 1):+.1f} % "
                      f"({'+' if abs(v.measured_N) >= abs(v.reference_N) else '-'}"
                      f"{fmt(units.show('force', abs(abs(v.measured_N) - abs(v.reference_N))), 2)} {units.unit('force')})"
                      for v in outside)
    return f"{head}; {failed} outside" + (f"{', the furthest' if furthest and failed > 1 else ''}: {where}" if where
                                           else "")


@dataclass
class Verdict:
    v_m_s: float
    direction: str  # "compression" or "rebound"
    reference_N: float
    measured_N: float
    band_N: float  # half-width of the band [N]

    @property
    def margin_N(self):
        """What is left of the band (negative: outside by that much)."""
        return self.band_N - abs(self.measured_N - self.reference_N)

    @property
    def passed(self):
        return self.margin_N >= 0


def verdicts(run_rows, ref_rows, tol: Tolerance, speeds=None, units=Units()) -> list[Verdict]:
    """Per speed (the velocity table's, [m/s]; by default the unit system's standard
    points) and direction where both were measured. Both are read the same way: along the
    stroke when either ran one speed only (velocity_table.method), else from the peaks."""
    how = vt.method(run_rows, ref_rows)
    out = _verdicts(run_rows, ref_rows, tol, speeds, units, how)
    if not out and speeds is None:  # a slow run: no standard speed reached; its own speeds
        out = _verdicts(run_rows, ref_rows, tol, vt.own_speeds(run_rows), units, "stroke")
    return out


def _verdicts(run_rows, ref_rows, tol, speeds, units, how):
    run = vt.velocity_table(run_rows, speeds, units, how)
    return compared(run, vt.velocity_table(ref_rows, [r.v_m_s for r in run], how=how), tol)


def compared(run, ref, tol: Tolerance) -> list[Verdict]:
    """Verdicts of two velocity tables at the same speeds, per speed and direction where
    both have a force."""
    out = []
    for a, b in zip(run, ref):
        for direction, m, r in (("compression", a.F_comp_N, b.F_comp_N), ("rebound", a.F_reb_N, b.F_reb_N)):
            if np.isfinite(m) and np.isfinite(r):
                out.append(Verdict(a.v_m_s, direction, r, m, float(tol.band(r))))
    return out


COMPENSATE_K = 2.0  # runs further apart than this in body temperature are compensated


@dataclass
class Check:
    results: list  # [Verdict]
    reference: str  # what the run was checked against, in words
    compensation: str = ""  # how temperature was compensated, or why it could not be; "" when not needed
    unmeasured: str = ""  # a table's points the run did not reach, or its motion a model was not identified on
    repeats: str = ""  # the repeats that differ that the tables leave out (velocity_table.repeats_note)


def _repeats(run, ref=None) -> str:
    said = [f"{who}: {note}" for who, note in (("run", vt.repeats_note(run)),
                                               ("reference", vt.repeats_note(ref or []))) if note]
    return " ".join(said)


TABLES = (".csv", ".txt", ".tsv", ".xlsx")  # --against: a force-velocity table (spec_table), not a run or model


class OtherSign(ValueError):
    """A run or reference in the other sign convention: no band can compare it."""


class NotComparable(UsageError):
    """A run and a reference that share no shaft speed or sign convention: no verdict (a
    comparison sheet says so for that run and goes on)."""


def _rows(path, model=None, at_K=None):
    """The recording's peaks; with a model, its force at the same instants (at the body
    temperature measured, or at at_K [K] for every segment when given)."""
    ch, events, meta = load_recording(path, None if getattr(model, "effects", None) else peaks.READS)
    sign = sign_problem(ch)
    if sign:
        raise OtherSign(f"{Path(path).name}: {sign}")
    model = peaks.along(model, ch, events, meta)
    if at_K is not None and "T_body" in ch:
        t = ch["T_body"][0]
        ch = {**ch, "T_body": (t, np.full(len(t), at_K))}
    segs = segments(events)
    return peaks.scattered(ch, segs, model) or peaks.peaks(ch, segs, damper=peaks.recorded_damper(meta), model=model)


def _table_temperature(rows):
    """Mean body temperature [C] of the segments the velocity table reads (a temperature
    sweep's are another curve), nan without any."""
    T = [p.T_c for p in rows if np.isnan(p.target_c) and np.isfinite(p.T_c)]
    return float(np.mean(T)) if T else np.nan


def check(path, against, tol: Tolerance, units=Units()) -> Check:
    """A run (path) against a reference: another run (a .mcap path) or a damper model (a
    preset's name or FILE.json) along the run's own motion. RigError, DamperError or
    ValueError name what cannot be read."""
    if Path(against).suffix.lower() in TABLES:
        return against_table(path, against, tol, units)
    if Path(against).suffix != ".mcap":
        model = load_damper(str(against))
        run = _rows(path, model)
        far = outside(getattr(model, "identified_on", None) or {}, [p.freq_hz for p in run],
                      [1e-3 * p.amplitude_mm for p in run],
                      float(np.nanmax([abs(v) for p in run for v in (p.v_comp, p.v_reb)] or [0.0])))
        return Check(verdicts(run, model_rows(run), tol, units=units), f"model {model.name} along this run's motion",
                     unmeasured=far, repeats=_repeats(run))
    run, ref = _rows(path), _rows(against)
    T_run, T_ref = (_table_temperature(rows) for rows in (run, ref))
    note = ""
    if abs(T_run - T_ref) > COMPENSATE_K:
        identified = Path(path).with_suffix(".model.json")
        try:
            model = load_damper(str(identified))
        except (DamperError, OSError, ValueError):
            model = None
        if model is None:
            minimal = Path(path).with_suffix(".minimal.json")
            why = (f"its model {minimal.name} has no temperature law to move the forces with (dyno identify "
                   f"--damper DESCRIPTION writes {identified.name}, which has)" if minimal.is_file() else
                   f"the run has no identified damper model ({identified.name}: dyno identify --damper "
                   f"DESCRIPTION writes it)")
            note = (f"not compensated for temperature: the run averaged {T_run:.0f} C, the reference "
                    f"{T_ref:.0f} C, and {why}")
        else:
            at_run, at_ref = _rows(path, model), _rows(path, model, T_ref + 273.15)
            run = [dataclasses.replace(p, F_comp=p.F_comp + b.model_comp - a.model_comp,
                                       F_reb=p.F_reb + b.model_reb - a.model_reb,
                                       stroke_F=p.stroke_F + b.model_stroke_F - a.model_stroke_F)
                   for p, a, b in zip(run, at_run, at_ref)]
            note = (f"compensated for temperature: the run's forces moved from its {T_run:.0f} C to the "
                    f"reference's {T_ref:.0f} C with its identified model {identified.name}")
    return Check(verdicts(run, ref, tol, units=units), Path(against).name, note, repeats=_repeats(run, ref))


def checked(path, against, tolerance: str, units=Units()) -> tuple[Check, Tolerance]:
    """`dyno check`'s and `dyno report --against`'s check: (Check, Tolerance) of the run
    against the reference, the tolerance as the user wrote it; UsageError names what cannot
    be read or compared."""
    from records.files import input_file
    try:
        tol = parse_tolerance(tolerance)
    except ValueError as e:
        raise UsageError(str(e)) from None
    if Path(against).suffix.lower() in (".mcap", *TABLES):
        input_file(against, "--against")
    try:
        out = check(path, against, tol, units)
    except OtherSign as e:
        raise NotComparable(str(e)) from None
    except (DamperError, OSError, ValueError) as e:
        raise UsageError(f"--against: {e}") from None
    if not out.results:
        raise NotComparable(f"{Path(path).name} and {out.reference}: no shaft speed measured in both: the check "
                         "reads the force at shaft speeds from sine or crank strokes, or from a random input's "
                         "force-velocity scatter, and these share none")
    return out, tol


def said(c: Check, tol: Tolerance, units=Units()) -> tuple[str, str]:
    """(the verdict sentence, what it is against) of a check, as the test sheet prints them."""
    failed = [r for r in c.results if not r.passed]
    return verdict(len(c.results), len(failed), failed, units, furthest=True), f"{c.reference}, tolerance {tol}"


def against_table(path, against, tol: Tolerance, units=Units()) -> Check:
    """A run against a force-velocity table (a spec sheet, another dyno's export): the
    run's force at the table's own speeds, read as its velocity table reads them."""
    spec = spec_table.read(against)
    run = _rows(path)
    got = vt.velocity_table(run, spec.v_m_s, units, vt.method(run))
    ref = [vt.VelocityRow(float(v), float(c), float(r)) for v, c, r in zip(spec.v_m_s, spec.F_comp_N, spec.F_reb_N)]
    missed = sorted({g.v_m_s for g, r in zip(got, ref) for m, f in ((g.F_comp_N, r.F_comp_N), (g.F_reb_N, r.F_reb_N))
                     if np.isfinite(f) and not np.isfinite(m)})
    said = ", ".join(fmt(units.show("velocity", v), 3) for v in missed)
    return Check(compared(got, ref, tol), f"table {Path(against).name}",
                 unmeasured=f"not measured by this run, outside the speeds it reached: the table's "
                            f"{said} {units.unit('velocity')}" if missed else "", repeats=_repeats(run))


def model_rows(rows):
    """Peaks whose forces are the model's at the same instants (peaks(..., model=M)): the
    reference a model gives along the run's own motion and temperature."""
    return [dataclasses.replace(p, F_comp=p.model_comp, F_reb=p.model_reb, stroke_F=p.model_stroke_F)
            for p in rows]


def band_figure(results, out_path, title, units=Units()):
    """The reference with its band and the run's points, per direction, as magnitudes."""
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for direction, c in (("compression", "C0"), ("rebound", "C1")):
        rs = sorted((r for r in results if r.direction == direction), key=lambda r: r.v_m_s)
        if not rs:
            continue
        v = units.show("velocity", np.array([r.v_m_s for r in rs]))
        ref = units.show("force", np.abs([r.reference_N for r in rs]))
        band = units.show("force", np.array([r.band_N for r in rs]))
        ax.fill_between(v, ref - band, ref + band, color=c, alpha=0.18, label=f"{direction}: reference band")
        ax.plot(v, ref, "--", color=c, lw=1)
        ok = np.array([r.passed for r in rs])
        meas = units.show("force", np.abs([r.measured_N for r in rs]))
        if ok.any():
            ax.plot(v[ok], meas[ok], "o", color=c, label=f"{direction}: run, inside")
        if (~ok).any():
            ax.plot(v[~ok], meas[~ok], "X", color=c, mec="red", ms=10, mew=1.5, label=f"{direction}: run, OUTSIDE")
    ax.set(title=title, xlabel=units.label("shaft velocity", "velocity"), ylabel=units.label("force magnitude", "force"))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return save(fig, out_path)
