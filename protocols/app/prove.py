"""`dyno prove`: hide each catalogue effect in the plain virtual rig (sim_backend/plain.toml)
at the level where its RMS contribution to the force equals the force sensor's noise (or a
multiple, --sizes; in the plant's other forms, --forms all; two at once, A+B), record the
prove sine matrix through the wire protocols, diagnose, and count.

Detection: the effect is the first accepted (a pair: both accepted), the valve curve's form
(the baseline's own law reshaped) and the cell's timing (the plant's own, named on its
nulls too) aside unless the row hides a timing. Wrong effect: something else came first (a pair:
something else accepted). False positive: physics claimed on a null recording (no hidden
effect): a catalogue effect or a term outside it; a timing offset of the cell or the valve
curve's form is no claim of physics (models/diagnose/spec.py NATURES).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from models.diagnose.candidates import CATALOGUE
from models.diagnose.candidates import EFFECTS as SPECS
from models.parallel import run_all
from models.recording import segments
from rig.errors import RigError
from protocols import cluster
from sim_backend.effects import EFFECTS, plain_cell, scaled

def _plan(override=None):
    from models.damper import load as load_damper
    from protocols.plan import rig_info
    from protocols.library import PROTOCOLS
    from rig import config as rig_config
    name, params, prove = plain_cell()
    module = PROTOCOLS[prove["protocol"]]
    p = module.Params(**(override or prove["params"]))
    damper = load_damper(name)
    return module, p, rig_info(rig_config.load("virtual"), damper), name, params, prove


def offline_recording(effects=None, seed=0, rate_hz=1000.0, params=None):
    """The plain plant driven by the prove plan (or `params` of the prove protocol) through
    the runner, without the wires, sampled at rate_hz: (channels {name: (t, values)},
    events, measured mask of the force samples). For calibration and the diagnosis
    benchmark; prove itself records through the wires. RigError if the run tripped."""
    import dataclasses

    from protocols import runner
    from rig import config as rig_config
    from rig.pacing import SimulatedPacer
    from rig.safety import Safety
    from sim_backend.direct_rig import DirectRig
    module, p, info, name, plant_params, _ = _plan(params)
    cfg = dataclasses.replace(rig_config.load("virtual"), rate_hz=rate_hz)
    rig = DirectRig(cfg, damper=name, seed=seed, effects=effects, params=plant_params)
    kept = runner.Kept()
    result, _ = runner.run(module, p, info, rig, SimulatedPacer(rig, rate_hz), Safety(cfg), [kept], progress=False)
    if result.fault:
        raise RigError(f"offline run with {effects or 'no effects'}: {result.fault}")
    channels = kept.arrays()
    t = channels["force"][0]
    measured = np.zeros(len(t), bool)
    for _, _, t0, t1 in segments(kept.events):
        measured |= (t > t0) & (t <= t1)
    return channels, kept.events, measured


def offline_force(effects, seed=0):
    """(force as measured, measured-segment mask) of offline_recording."""
    ch, _, rec = offline_recording(effects, seed)
    return ch["force"][1], rec


def contribution(effect, value, seed=0, null=None, form=None):
    """RMS [N] of what the effect (in the plant's `form`, default None) adds to the
    measured force (same noise seed, so the noise cancels); for a sensor lag, of the force
    against itself shifted by the lag (every form delays by about its value)."""
    F0, rec = null if null is not None else offline_force({}, seed)
    if effect == "sensor_delay":
        t = np.arange(len(F0)) * 1e-3
        d = F0 - np.interp(t - value, t, F0)
    else:
        try:
            F1, _ = offline_force({effect: value, **({"forms": {effect: form}} if form else {})}, seed)
        except RigError:  # so large the run tripped: far above any target
            return math.inf
        d = F1 - F0
    return float(np.sqrt(np.mean(d[rec] ** 2)))


def key(effect, form=None):
    """An effect's key in plain.toml's [prove.concealed]: EFFECT, or EFFECT:FORM."""
    return f"{effect}:{form}" if form else effect


def calibrate_one(task):
    """(value, its contribution [N]): the largest VALUE of effect e in `form` whose
    contribution is at most `target`, by bisection on a log scale."""
    e, form, target = task
    null = offline_force({}, 0)
    lo, hi = 1e-3, 1e3  # strengths about the guess
    if e == "compressibility":  # no stiffer than the plain cell's oil (1e12 Pa)
        lo = EFFECTS[e].guess / 1e12
    for _ in range(12):
        s = math.sqrt(lo * hi)
        c = contribution(e, scaled(e, EFFECTS[e].guess, s), 0, null, form)
        lo, hi = (s, hi) if c < target else (lo, s)
    value = float(f"{scaled(e, EFFECTS[e].guess, lo):.4g}")
    return value, contribution(e, value, 0, null, form)


def calibrate(target, progress, effects=None, forms=False, pool=None):
    """{EFFECT or EFFECT:FORM: value} with contribution == target, in the default form of
    each effect (and in every other form, forms=True)."""
    keys = [(e, f) for e in EFFECTS if not effects or e in effects
            for f in [None, *(EFFECTS[e].forms if forms else ())]]
    names = [key(e, f) for e, f in keys]
    results = run_all(calibrate_one, [(e, f, target) for e, f in keys], pool, progress=True, label="calibrate",
                      names=names)
    for n, (e, _), (v, c) in zip(names, keys, results):
        progress(f"{n} = {v:g} {EFFECTS[e].unit} (contribution {c:.2f} N)")
    return {n: v for n, (v, _) in zip(names, results)}


def run_task(task):
    """Record one prove run through the wire protocols, diagnose it."""
    effect, form, size, values, seed, noise, rate, *extra = task
    with tempfile.TemporaryDirectory(prefix="dyno-prove-") as folder:  # on the worker's own disk
        return _recorded(effect, form, size, values, seed, noise, rate, folder, *extra)


def _recorded(effect, form, size, values, seed, noise, rate, folder, extra=None):
    from models.diagnose import diagnose
    from protocols.app.run import run as run_protocol
    from protocols.io.reader import load_recording
    _, _, prove = plain_cell()
    out = Path(folder) / f"{effect or 'null'}-{form or 'default'}-{size:g}-{noise:g}-{rate:g}-{seed}.mcap"
    pairs = [f"{k}={','.join(str(x) for x in v) if isinstance(v, list) else v}" for k, v in prove["params"].items()]
    args = argparse.Namespace(protocol=prove["protocol"], params=pairs, rig=None, damper=None, out=str(out),
                              overwrite=True, long=False, realtime=False, live=False, rrd=None, identify=False,
                              plain=True, seed=seed, noise=noise, rate_hz=rate,
                              effect=[f"{e}{':' + form if form else ''}={v}" for e, v in (values or {}).items()]
                              + ([f"extra:{extra}"] if extra else []), progress=False)
    import contextlib
    import io
    with contextlib.redirect_stderr(io.StringIO()):
        run_protocol(args)
    ch, ev, _ = load_recording(out)
    r = diagnose(ch, ev)
    hidden = set(effect.split("+")) if effect else set()
    # the valve curve's form and the cell's own timing (the plant's, on every null) are not
    # what a row hides unless it hides that: they do not take the first place
    named = [e for e in r.accepted
             if SPECS[e.split(":")[0]].nature not in ("form", "cell") or e.split(":")[0] in hidden]
    first = named[0].split(":")[0] if named else None
    est = None
    if first and effect and first == effect:  # a single effect (a pair's name has a "+")
        est = next(s.parameters for s in r.steps if s.effect == named[0]).get(CATALOGUE[effect].estimate)
    t, F = ch["force"]
    measured = np.zeros(len(t), bool)
    for _, _, t0, t1 in segments(ev):
        measured |= (t >= t0) & (t < t1)
    # what the caller needs travels back with the result: the workers share no disk
    # an effect accepted beside the hidden ones: said as left-out physics, or as "may be
    # compensating the form of" an earlier one (docs/diagnosis.md)
    # a timing offset of the cell or the valve curve's form is no claim of physics
    # (models/diagnose/spec.py NATURES): not counted against a null or as an extra
    claims = [e for e in r.accepted if SPECS[e.split(":")[0]].nature in ("physics", "open")]
    extra = [s for s in r.steps if s.effect.split(":")[0] not in hidden and s.effect in claims]
    return {"effect": effect, "form": form, "size": size, "noise": noise, "rate": rate, "seed": seed,
            "accepted": r.accepted, "claims": claims, "first": first, "noise_sd": r.noise_sd,
            "found": [{k: getattr(s, k) for k in ("effect", "nature", "depends_on", "region", "size_rms_n")}
                      for s in r.steps if not s.replaced_by],
            "within_noise": r.left_over.within_noise,
            "rmse": (r.baseline.rmse_heldout, r.final.rmse_heldout),
            "extra_left_out": any(not s.compensates for s in extra),
            "extra_compensating": any(s.compensates for s in extra), "force_t": t, "force": F, "measured": measured,
            "estimate": est,
            "before": r.baseline.nrmse_heldout, "after": r.final.nrmse_heldout}


def _measured_rms_diff(a, b):
    """RMS [N] of the force difference of two prove results over a's measured samples."""
    _, ia, ib = np.intersect1d(np.round(a["force_t"], 6), np.round(b["force_t"], 6), return_indices=True)
    return float(np.sqrt(np.mean((a["force"][ia] - b["force"][ib])[a["measured"][ia]] ** 2)))


def _table(results, effects, concealed):
    """A row per (effect, form, size) of the runs' results: detection, wrong effect, false
    positives, medians of the estimate, contribution and held-out errors."""
    table = []
    row_key = (lambda r: (r["effect"] or "null", r["form"], r["size"], r["noise"], r["rate"]))
    rows = sorted({row_key(r) for r in results}, key=lambda k: ([*effects, "null"].index(k[0]), k[1] or "", *k[2:]))
    for e, form, size, noise, rate in rows:
        rs = [r for r in results if row_key(r) == (e, form, size, noise, rate)]
        parts = set(e.split("+"))
        named = [{a.split(":")[0] for a in r["accepted"]} for r in rs]
        row = {"effect": e, "form": form or ("default" if e != "null" else None), "size": size, "noise": noise,
               "rate_hz": rate, "n": len(rs),
               "value": (scaled(e, concealed[key(e, form)], size * noise) if key(e, form) in concealed
                         else None),
               # a single effect: the first accepted; a pair: both accepted, in either order
               "detection": (float(np.mean([r["first"] == e for r in rs])) if e in EFFECTS
                             else float(np.mean([parts <= n for n in named])) if e != "null" else None),
               "wrong_effect": (float(np.mean([r["first"] not in (None, e) for r in rs])) if e in EFFECTS
                                else float(np.mean([bool(n - parts) for n in named])) if e != "null" else None),
               "false_positive": float(np.mean([bool(r["claims"]) for r in rs])) if e == "null" else None,
               # beside the hidden effect(s): another said as left out, or as may be compensating
               "extra_left_out": float(np.mean([r["extra_left_out"] for r in rs])) if e != "null" else None,
               "extra_compensating": float(np.mean([r["extra_compensating"] for r in rs])) if e != "null" else None,
               "heldout_before": float(np.median([r["before"] for r in rs])),
               "heldout_after": float(np.median([r["after"] for r in rs])),
               "estimate": (float(np.median([r["estimate"] for r in rs if r["estimate"] is not None]))
                            if any(r["estimate"] is not None for r in rs) else None),
               "contribution_rms": (float(np.median([r["contribution"] for r in rs if "contribution" in r]))
                                    if any("contribution" in r for r in rs) else None)}
        table.append(row)
    return table


def run(args):
    _, params, prove = plain_cell()
    say = (lambda s: print(s, file=sys.stderr, flush=True))
    noise = params["sensors"]["force_noise"]
    if args.calibrate:
        with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
            vals = calibrate(noise, say, args.effects.split(",") if args.effects else None, args.forms == "all", pool)
        print("[prove.concealed]")
        for e, v in vals.items():
            print(f'"{e}" = {v:g}' if ":" in e else f"{e} = {v:g}")
        return 0
    if getattr(args, "open", None) is not None:  # an empty EXPR is refused there, not ignored
        return prove_open(args, say)
    concealed = prove.get("concealed", {})
    named = ([n for e in args.effects.split(",") for n in (EFFECTS if e == "ALL" else [e])] if args.effects
             else list(EFFECTS) + ["null"])  # ALL: every effect
    effects = list(dict.fromkeys(e.partition(":")[0] for e in named))  # EFFECT:FORM proves that form only
    variants = list(dict.fromkeys((e.partition(":")[0], e.partition(":")[2] or None) for e in named))
    bad = [f"{e}:{f}" for e, f in variants if f and e in EFFECTS and f not in EFFECTS[e].forms]
    if bad:
        raise RigError(f"--effects: {bad[0]}: no such form (sim_backend/effects.py FORMS)")
    args.sizes = getattr(args, "sizes", None) or [1.0]
    unknown = [e for e in effects if e != "null" and not set(e.split("+")) <= set(EFFECTS)]
    if unknown:
        raise RigError(f"--effects: unknown effect {unknown[0]!r} (known: {', '.join(EFFECTS)}, null, and pairs "
                       f"A+B hidden together)")
    if not all(200.0 <= r <= 10000.0 for r in args.rates):
        raise RigError(f"--rates: the virtual cell runs at 200-10000 Hz, not {', '.join(f'{r:g}' for r in args.rates)}")
    if args.forms == "all":  # each effect also in the plant's other forms (sim_backend/effects.py FORMS)
        variants = [v for e in effects
                    for v in [(e, None)] + [(e, f) for f in (EFFECTS[e].forms if e in EFFECTS else ())]]
    for e, form in variants:  # each form at its own noise floor
        for part in (e.split("+") if e != "null" else ()):
            if key(part, form) not in concealed:
                say(f"dyno: error: no concealed value for {key(part, form)!r} in sim_backend/plain.toml "
                    f"(run dyno prove --calibrate{' --forms all' if form else ''})")
                return 2
    tasks = []
    for seed in range(args.seeds):
        for level, rate in [(n, r) for n in args.noise for r in args.rates]:
            for e, form in variants:
                for size in ([1.0] if e == "null" else args.sizes):
                    # a size is a multiple of the noise floor at this noise level
                    values = None if e == "null" else {
                        p: scaled(p, concealed[key(p, form)], size * level) for p in e.split("+")}
                    tasks.append((None if e == "null" else e, form, size, values, seed, level, rate))
            if "null" not in effects:  # the contribution is measured against the null of the same seed
                tasks.append((None, None, 1.0, None, seed, level, rate))
    names = [f"{e or 'null'} {form or ''} x{size:g} noise x{level:g} {rate:g} Hz seed {seed}"
             for e, form, size, _, seed, level, rate in tasks]
    with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
        results = run_all(run_task, tasks, pool, progress=True, label="prove", names=names)
    for name, r in zip(names, results):
        say(f"{name}: accepted {r['accepted'] or 'nothing'}")
    nulls = {(r["seed"], r["noise"], r["rate"]): r for r in results if r["effect"] is None}
    for r in results:
        if r["effect"]:
            r["contribution"] = _measured_rms_diff(r, nulls[r["seed"], r["noise"], r["rate"]])
    table = _table(results, effects, concealed)
    doc = {"noise_rms": noise, "seeds": args.seeds, "effects": table,
           "goals": {"detection": 0.9, "false_positive": 0.05}}
    if args.json:
        print(json.dumps(doc, indent=1))
    else:
        _print(table, args, noise)
    return 0


def prove_open(args, say):
    """`dyno prove --open EXPR`: the user's own physics (sim_backend/extra.py) hidden in the
    plain cell, each seed against the null of the same seed: what the diagnosis names,
    what it depends on, where it lives, and how much of the held-out error above the
    noise it explains."""
    from sim_backend.effects import EffectError, parse
    try:
        parse([f"extra:{args.open}"])
    except EffectError as e:
        raise RigError(str(e).replace("--effect extra:", "--open ")) from None
    level, rate = args.noise[0], args.rates[0]
    tasks = [t for seed in range(args.seeds) for t in ((None, None, 1.0, None, seed, level, rate),
                                                        (None, None, 1.0, None, seed, level, rate, args.open))]
    with cluster.pool(getattr(args, "cluster", None), args.jobs) as (pool, _):
        results = run_all(run_task, tasks, pool, progress=True, label="prove --open",
                          names=[f"{'open' if len(t) > 7 else 'null'} seed {t[4]}" for t in tasks])
    rows = []
    for null, r in zip(results[::2], results[1::2]):
        size = _measured_rms_diff(r, null)
        base, final = (e ** 2 for e in r["rmse"])
        explained = 1.0 - max(final - r["noise_sd"] ** 2, 0.0) / max(base - r["noise_sd"] ** 2, 1e-12)
        rows.append({"seed": r["seed"], "contribution_rms": size, "null_claims": null["claims"],
                     "found": r["found"], "explained": explained, "within_noise": r["within_noise"]})
    if args.json:
        print(json.dumps({"expression": args.open, "rate_hz": rate, "noise": level, "runs": rows}, indent=1))
        return 0
    print(f"extra: {args.open}  (x [m], v [m/s], t [s], T [K]; {rate:g} Hz, noise x{level:g})")
    for row in rows:
        found = "; ".join(f"{f['effect']} ({f['nature']}: {', '.join(f['depends_on'] or [])}; {f['region']}; "
                          f"{f['size_rms_n']:.3g} N RMS)" for f in row["found"]) or "nothing"
        print(f"seed {row['seed']}: hidden {row['contribution_rms']:.3g} N RMS; named {found}; "
              f"{100 * row['explained']:.0f} % of the held-out error above the noise explained"
              f"{'' if row['within_noise'] else '; some left unexplained'}"
              f"{'; the null claimed ' + ', '.join(row['null_claims']) if row['null_claims'] else ''}")
    return 0


HEADER = ("effect", "form", "size", "noise", "rate [Hz]", "hidden value", "force contribution RMS [N]", "detection",
          "wrong effect", "false positive", "also named: left out / may compensate", "estimate (median)",
          "held-out NRMSE before / after [%]")


def _cells(r):
    f = (lambda v, fmt: format(v, fmt) if v is not None else "-")
    return (r["effect"], f(r["form"], "s"), f"x{r['size']:g}", f"x{r['noise']:g}", f"{r['rate_hz']:g}",
            f(r["value"], ".3g"), f(r["contribution_rms"], ".2f"), f(r["detection"], ".0%"),
            f(r["wrong_effect"], ".0%"), f(r["false_positive"], ".0%"),
            f"{f(r['extra_left_out'], '.0%')} / {f(r['extra_compensating'], '.0%')}", f(r["estimate"], ".3g"),
            f"{100 * r['heldout_before']:.4f} / {100 * r['heldout_after']:.4f}")


def _print(table, args, noise):
    rows = [_cells(r) for r in table]
    if not getattr(args, "markdown", False):
        widths = [max(len(c) for c in col) for col in zip(HEADER, *rows)]
        for row in (HEADER, *rows):
            print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
        return
    from protocols.reports import markdown as md
    from sim_backend.effects import FORMS
    used = sorted({(r["effect"], r["form"]) for r in table if r["form"] not in (None, "default")},
                  key=lambda k: (list(EFFECTS).index(k[0]) if k[0] in EFFECTS else 99, k[1]))
    forms = [(e, "default", EFFECTS[e].form) for e in dict.fromkeys(e for e, _ in used) if e in EFFECTS]
    forms += [(e, f, FORMS[f"{e}:{f}"]) for e, f in used if f"{e}:{f}" in FORMS]
    body = md.table(HEADER, rows)
    if forms:
        body += "\n\nThe forms (sim_backend/effects.py):\n\n" + md.table(("effect", "form", "in the plant"),
                                                                       sorted(forms, key=lambda r: (list(EFFECTS).index(r[0]), r[1] != "default", r[1])))
    print(md.document("Proof of the diagnosis (dyno prove)", body,
                      f"{args.seeds} seeds per row on the plain cell through the wires; force noise {noise:g} N RMS "
                      f"at noise x1 (every sensor's noise times the noise column). Size x1 is the concealed value "
                      f"at that noise (its contribution equals the force noise, each form calibrated on its own); x10 ten times "
                      f"as strong (a bulk modulus divided by ten, a breakaway ratio's excess times ten); forms: "
                      f"sim_backend/effects.py FORMS. Goals: detection >= 90 %, false positives <= 5 %. Method: "
                      f"docs/diagnosis.md."))
