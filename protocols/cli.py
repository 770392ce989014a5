"""The `dyno` command line. Errors in what the user gave us are one line and exit 2."""
from __future__ import annotations

import argparse
import json
import math
import sys

from models.damper import DamperError, load
from rig.errors import RigError


def _emit(args, title, result, text, body=None, note=""):
    """A command's result: JSON (--json), a stamped Markdown page for docs/results
    (--markdown; body defaults to a table of the result's values) or text lines."""
    if getattr(args, "json", False):
        print(json.dumps(result, indent=2))
    elif getattr(args, "markdown", False):
        from protocols.reports import markdown as md
        print(md.document(title, body if body is not None else md.table(("quantity", "value"), md.flat(result)), note))
    else:
        print(text)
    return 0


def _validate(args):
    from models.validation import format_table, rows
    from protocols.reports import markdown as md
    r = rows()
    body = []
    for group in dict.fromkeys(x["group"] for x in r):
        g = [x for x in r if x["group"] == group]
        body.append(f"## {group} rows: {sum(x['pass'] for x in g)} of {len(g)} pass\n\n" + md.table(
            ("source", "case", "unit", "thesis", "model", "error", "tolerance", "pass", "kind"),
            [(x["source"], x["case"], x["unit"], f"{x['thesis']:.4g}", f"{x['model']:.4g}",
              "-" if x["rel_error"] is None else f"{100 * x['rel_error']:.1f} %",
              f"±{x['tolerance']:g} {x['unit']}" if x["tolerance_type"] == "absolute" else f"{100 * x['tolerance']:.0f} %",
              "PASS" if x["pass"] else "**FAIL**", x["note"]) for x in g]))
    n = sum(x["pass"] for x in r)
    return _emit(args, "Validation against the thesis", {"rows": r}, format_table(r), "\n\n".join(body),
                 f"{n} of {len(r)} rows pass. Why rows fail: docs/model.md.")


def _plot_damper(args):
    from protocols.reports.plots import plot_damper
    d = load(args.damper)
    if d.layout == "simplified":
        raise DamperError(f"{d.name}: simplified models have no loops to plot (damping only, eq 6.1/6.2)")
    if not 0 < args.amplitude_mm * 1e-3 <= d.geometry.stroke / 2:
        raise DamperError(f"--amplitude-mm must be in (0, {d.geometry.stroke * 500:.1f}] for {d.name}")
    if any(f <= 0 or f > 100 for f in args.freq):
        raise DamperError("--freq values must be in (0, 100] Hz")
    for p in plot_damper(d, _out_dir(args.out), args.amplitude_mm * 1e-3, tuple(args.freq), args.temp):
        print(p)
    return 0


def _freqs(args):
    from models.quarter_car.sweeps import FREQS
    return FREQS if args.freq is None else args.freq


def _plot_quarter_car(args):
    from models import quarter_car as qcm
    from protocols.reports import quarter_car as qp
    from models.quarter_car import sweeps
    car = qcm.load(args.car)
    d = load(args.damper)
    T = float(args.temp) + 273.15
    out = _out_dir(args.out)
    fr = sweeps.frequency_response(car, d, [a * 1e-3 for a in args.amplitude_mm], _freqs(args), T=T,
                                   workers=args.workers, progress=True)
    print(qp.plot_frequency_response(fr, out / f"frequency-response-{d.name}.png"))
    if d.layout != "simplified":
        steps = [(A, *sweeps.step_response(car, d, A, T=T)) for A in (0.025, -0.025, 0.0508)]
        print(qp.plot_steps(steps, out / f"step-response-{d.name}.png",
                            f"Quarter car '{car.name}' with {d.name} at {args.temp:g} C: road steps"))
    for i, A in enumerate(fr.amplitudes):
        on_stops = fr.freqs[fr.values["stop_fraction"][i] > 0]
        if on_stops.size:
            print(f"note: at {A * 1e3:.1f} mm the damper reaches its stops between {on_stops[0]:.2f} and "
                  f"{on_stops[-1]:.2f} Hz", file=sys.stderr)
    return 0


def _plot_parametric(args):
    from models import quarter_car as qcm
    from protocols.reports import quarter_car as qp
    from models.quarter_car import sweeps
    car = qcm.load(args.car)
    study = sweeps.parametric_study(car, args.damper, [a * 1e-3 for a in args.amplitude_mm], _freqs(args),
                                    workers=args.workers, progress=True)
    for p in qp.plot_parametric(study, _out_dir(args.out), args.damper):
        print(p)
    return 0


def _plot_simplified(args):
    from models import quarter_car as qcm
    from protocols.reports import quarter_car as qp
    from models.quarter_car import sweeps
    res = sweeps.simplified_comparison(qcm.load(args.car), args.damper, freqs=_freqs(args),
                                       workers=args.workers, progress=True)
    print(qp.plot_simplified(res, _out_dir(args.out) / "simplified-models.png"))
    return 0


def _out_dir(path):
    from protocols.files import make_dir
    return make_dir(path)


def _bench_sweep(args):
    from protocols.bench_sim import bench_sweep
    result = bench_sweep(workers=args.workers)
    text = (f"{result['damper']} sweep, {result['points']} points ({len(result['amplitudes_m'])} amplitudes x "
            f"{len(result['freqs_hz'])} frequencies, {result['simulated_s']:.0f} s simulated) on "
            f"{result['workers']} workers: {result['wall_s']:.1f} s wall "
            f"(goal < {result['goal_wall_s']:.0f} s: {'met' if result['goal_met'] else 'NOT met'})")
    return _emit(args, "Quarter-car sweep time (dyno bench sweep)", result, text)


def _bench_loop(args):
    from protocols.bench_loop import bench_loop, goals_met
    if not 0 < args.rate <= 5000 or not 0 < args.seconds <= 3600:
        raise RigError("--rate must be in (0, 5000] Hz and --seconds in (0, 3600]")
    from protocols.bench_loop import baseline
    stats = bench_loop(args.rate, args.seconds)
    stats["goals_met"] = goals_met(stats)
    stats["machine_baseline"] = baseline(args.rate, args.seconds)
    j, b = stats["jitter_us"], stats["machine_baseline"]
    lines = [f"loop at {stats['rate_hz_target']:g} Hz for {args.seconds:g} s against sim-rig: achieved "
          f"{stats['rate_hz']:.1f} Hz, jitter p50 {j['p50']:.0f} us, p99 {j['p99']:.0f} us, p99.9 {j['p999']:.0f} us, "
          f"overruns {stats['overruns']} of {stats['ticks']} ticks"
          + (f", FAULT: {stats['fault']}" if stats["fault"] else ""),
             f"machine baseline (a bare sleep loop, same rate and duration, no rig): {b['late_beyond_period']} of "
          f"{b['ticks']} ticks late by more than a period, worst {b['max_late_us']:.0f} us"]
    if stats["goals_met"] is not None:
        lines.append("goals: " + ("met" if stats["goals_met"] else "NOT met"))
    return _emit(args, "Control-loop timing (dyno bench loop)", stats, "\n".join(lines))


def _bench_log(args):
    from protocols.bench import bench_log
    r = bench_log(args.seconds)
    text = (f"MCAP logging: {r['samples_per_s']:,.0f} samples/s sustained ({r['bytes_per_sample']:.1f} bytes/sample "
            f"on disk), {r['ratio']:.0f}x the {r['protocol_samples_per_s']:,.0f} samples/s a protocol records "
            f"(goal >= {r['goal_ratio']:.0f}x: {'met' if r['goal_met'] else 'NOT met'})")
    return _emit(args, "MCAP logging rate (dyno bench log)", r, text)


def _bench_diagnose(args):
    from protocols.bench import bench_diagnose
    r = bench_diagnose(args.seconds, args.rate)
    text = (f"diagnosed {r['recording_s']:.0f} s at {r['rate_hz']:.0f} Hz ({r['samples']} samples per channel) "
            f"in {r['diagnose_s']:.1f} s (goal < {r['goal_s']:.0f} s); accepted {r['accepted'] or 'nothing'}")
    return _emit(args, "Diagnosis time (dyno bench diagnose)", r, text)


def _bench_identify(args):
    from protocols.bench import bench_identify
    r = bench_identify(args.recording, args.damper)
    text = (f"identify {r['recording']}: {r['wall_s']:.1f} s wall (goal < {r['goal_wall_s']:.0f} s: "
            f"{'met' if r['goal_met'] else 'NOT met'}), held-out loop NRMSE {100 * r['heldout_nrmse']:.2f} %")
    return _emit(args, "Identification time (dyno bench identify)", r, text)


def _bench_sim(args):
    from protocols.bench_sim import bench
    from protocols.reports import markdown as md
    result = bench(seconds=args.seconds, ref_seconds=args.ref_seconds)
    goals = "goals (>= 200x real time, >= 10x reference, < 0.5 % force): " + ("met" if result["goals_met"] else "NOT met")
    lines = [f"{name:10s} real-time factor {c['realtime_factor']:7.0f}x   "
             f"vs solve_ivp Radau {c['speedup_vs_reference']:6.0f}x   "
             f"max force diff {100 * c['max_force_diff_fraction']:.3f} % of peak" for name, c in result["cases"].items()]
    body = md.table(("damper", "real-time factor", "vs solve_ivp Radau", "max force difference"),
                    [(n, f"{c['realtime_factor']:.0f}x", f"{c['speedup_vs_reference']:.0f}x faster",
                      f"{100 * c['max_force_diff_fraction']:.2f} % of peak") for n, c in result["cases"].items()])
    return _emit(args, "Damper model speed (dyno bench sim)", result, "\n".join(lines + [goals]), body,
                 f"{args.seconds:g} s simulated per damper, 12.7 mm at 16 Hz, output every 0.1 ms; {goals}.")


def _identify(args):
    from protocols.identification import run
    return run(args)


def _diagnose(args):
    from protocols.diagnosis import run
    return run(args)


def _prove(args):
    from protocols.prove import run
    return run(args)


def _import(args):
    from protocols.csv_import import run
    return run(args)


def _hidden_physics(p):
    from sim_backend.effects import EFFECTS
    p.add_argument("--effect", action="append", metavar="NAME=VALUE",
                   help="hide physics in the virtual rig: " + ", ".join(f"{n} [{u}]" for n, (u, _) in EFFECTS.items()))
    p.add_argument("--plain", action="store_true",
                   help="the plain cell dyno prove uses (sim_backend/plain.toml): nothing the minimal model leaves out")
    p.add_argument("--seed", type=number(0, 2**32 - 1, integer=True), default=0,
                   help="the virtual rig's noise seed (default 0)")


class Parser(argparse.ArgumentParser):
    """Usage mistakes are one line, like every other bad input, and exit 2."""

    def error(self, message):
        where = self.prog.removeprefix("dyno").strip()
        self.exit(2, f"dyno: error: {where + ': ' if where else ''}{message}\n")


def number(lo=None, hi=None, integer=False, above=None):
    """An argparse type: a finite number (an integer if asked) within [lo, hi], above `above`."""
    def parse(text):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if integer else 'a number'}") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        if above is not None and not v > above:
            raise argparse.ArgumentTypeError(f"must be above {above:g}, got {text}")
        if lo is not None and v < lo or hi is not None and v > hi:
            raise argparse.ArgumentTypeError(f"must be within {lo if lo is not None else '-inf'}..{hi}, got {text}")
        return v
    return parse


def parser():
    p = Parser(prog="dyno", description="Damper dyno controller and damper model tools")
    sub = p.add_subparsers(dest="cmd", required=True)
    for add in (_model_commands, _cell_commands, _analysis_commands, _bench_commands):
        add(sub)
    return p


def _model_commands(sub):
    """The damper model on its own: the thesis validation and plots."""
    v = sub.add_parser("validate", help="reproduce the thesis validation table")
    v.add_argument("--json", action="store_true", help="machine-readable {\"rows\": [...]}")
    v.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    v.set_defaults(func=_validate)
    pl = sub.add_parser("plot", help="write plots as PNG")
    plsub = pl.add_subparsers(dest="what", required=True)
    pd = plsub.add_parser("damper", help="loops, composite curve, temperature and pressure plots")
    pd.add_argument("damper", help="preset name (koni, mechformance, fox-light, fox-heavy) or FILE.json")
    pd.add_argument("--out", required=True, help="output directory")
    pd.add_argument("--amplitude-mm", type=number(), default=12.7, help="sine amplitude (default 12.7)")
    pd.add_argument("--freq", type=number(), nargs="+", default=[1, 2, 4, 8, 16], help="frequencies in Hz")
    pd.add_argument("--temp", type=number(), default=94.0, help="damper temperature in C (default 94)")
    pd.set_defaults(func=_plot_damper)
    for name, helptext, func in (
            ("quarter-car", "frequency and step responses of a quarter car (6.2)", _plot_quarter_car),
            ("parametric", "parametric study of one damper (6.3)", _plot_parametric),
            ("simplified", "simplified models I and II against the comprehensive model (6.4)",
             _plot_simplified)):
        q = plsub.add_parser(name, help=helptext)
        q.add_argument("--damper", default="koni", help="preset name or FILE.json (default koni)")
        q.add_argument("--car", default="race-car" if name == "parametric" else "simulator",
                       help="quarter-car preset (simulator, simulator-9kg, race-car) or FILE.json")
        q.add_argument("--out", required=True, help="output directory")
        q.add_argument("--freq", type=number(), nargs="+", default=None,
                       help="excitation frequencies in Hz (default 1.25-20 in 0.25 Hz steps)")
        if name != "simplified":
            q.add_argument("--amplitude-mm", type=number(), nargs="+", default=[3.2, 12.7],
                           help="road amplitudes in mm (default 3.2 12.7)")
        if name == "quarter-car":
            q.add_argument("--temp", type=number(), default=90.0, help="damper temperature in C (default 90)")
        q.add_argument("--workers", type=number(1, 256, integer=True), default=None,
                       help="processes (default: all cores)")
        q.set_defaults(func=func)


def _cell_commands(sub):
    """The test cell: serve the virtual rig, run a protocol, recover and report recordings."""
    from protocols import commands
    sr = sub.add_parser("sim-rig", help="serve the virtual rig as its own process (CAN socketcand, pty, Modbus TCP)")
    sr.add_argument("--config", default="sim-rig", help="rig config to serve (default: sim-rig)")
    sr.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    sr.add_argument("--fault", action="append", metavar="NAME[@TIME]", help="inject a fault, at TIME s")
    _hidden_physics(sr)
    sr.add_argument("--seconds", type=number(above=0), default=None, help="stop after this long")
    sr.set_defaults(func=commands.sim_rig)
    rn = sub.add_parser("run", help="run a test protocol and record it to MCAP")
    rn.add_argument("protocol", help="static, low-speed, sine-matrix, temperature-sweep, step, standard")
    rn.add_argument("params", nargs="*", metavar="name=value", help="protocol parameters (lists comma-separated)")
    rn.add_argument("--rig", default=None, help="rig config (default: the embedded virtual rig)")
    rn.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    _hidden_physics(rn)
    rn.add_argument("--out", default=None, help="recording FILE.mcap (default recordings/PROTOCOL-TIME.mcap); "
                                                "an existing file is kept unless --overwrite")
    rn.add_argument("--overwrite", action="store_true", help="replace an existing --out file once the run starts")
    rn.add_argument("--long", action="store_true", help="allow a run planned to move for more than 2 hours")
    rn.add_argument("--realtime", action="store_true", help="run the virtual rig in real time")
    rn.add_argument("--live", action="store_true", help="stream to a rerun viewer")
    rn.add_argument("--rrd", default=None, help="also save the live view to FILE.rrd")
    rn.add_argument("--identify", action=argparse.BooleanOptionalAction, default=None,
                    help="identify the damper while the test runs and write RECORDING.model.json "
                         "(default: on for the standard sequence)")
    rn.set_defaults(func=commands.run_protocol)
    rv = sub.add_parser("recover", help="rebuild a recording cut short (the original is kept as FILE.damaged)")
    rv.add_argument("file")
    rv.set_defaults(func=commands.recover_file)
    rp = sub.add_parser("report", help="HTML report with plots of a recording")
    rp.add_argument("file")
    rp.add_argument("--out", required=True, help="output directory")
    rp.set_defaults(func=commands.report_file)
    rg = sub.add_parser("rig", help="the test cell")
    rgsub = rg.add_subparsers(dest="what", required=True)
    rc = rgsub.add_parser("check", help="connect to every device and print each channel")
    rc.add_argument("--rig", default=None, help="rig config (default: the embedded virtual rig)")
    rc.add_argument("--damper", default="koni", help="damper in the embedded virtual rig (default koni)")
    rc.set_defaults(func=commands.rig_check)


def _analysis_commands(sub):
    """From recordings: identify, diagnose, prove the diagnosis, import CSV."""
    idf = sub.add_parser("identify", help="damper model from recordings (thesis chapter 4)")
    idf.add_argument("recordings", nargs="+", metavar="RECORDING", help="MCAP files (dyno run or dyno import)")
    idf.add_argument("--damper", default=None,
                     help="description giving layout and geometry (default: the damper the recording names)")
    idf.add_argument("--out", default=None, help="model JSON (default: RECORDING.model.json)")
    idf.add_argument("--truth", default=None, help="known damper (preset or JSON) to compare with")
    idf.add_argument("--json", action="store_true", help="results as JSON on stdout")
    idf.add_argument("--report", default=None, metavar="DIR", help="HTML report with loops and held-out errors")
    idf.set_defaults(func=_identify)
    dg = sub.add_parser("diagnose", help="where the model misses a recording and what physics was left out")
    dg.add_argument("recording")
    dg.add_argument("--baseline", default="minimal",
                    help="minimal (default: fitted whole), or a damper preset or model JSON, refitted")
    dg.add_argument("--json", action="store_true", help="machine-readable result")
    dg.add_argument("--report", metavar="DIR", help="HTML report with residual maps and loops")
    dg.set_defaults(func=_diagnose)
    pv = sub.add_parser("prove", help="hide each effect in the virtual rig at the noise level and diagnose it")
    pv.add_argument("--seeds", type=number(1, 10000, integer=True), default=10,
                    help="recordings per effect (default 10)")
    pv.add_argument("--effects", help="comma-separated subset of effects (default: all, plus nulls)")
    pv.add_argument("--json", action="store_true")
    pv.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    pv.add_argument("--calibrate", action="store_true",
                    help="find each effect's concealed value (contribution = force noise) and print it")
    pv.add_argument("--jobs", type=number(1, 256, integer=True), default=2,
                    help="recordings made and diagnosed in parallel (default 2)")
    pv.set_defaults(func=_prove)
    im = sub.add_parser("import", help="a CSV recording from elsewhere as an MCAP recording")
    im.add_argument("file", metavar="FILE.csv")
    im.add_argument("--out", required=True, metavar="FILE.mcap")
    im.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    im.add_argument("--map", action="append", required=True, metavar="NAME=COLUMN[:UNIT]",
                    help="time, displacement, velocity, force, temperature, pressure or aux.NAME; "
                         "units e.g. ms, mm, mm/s, kN, C, bar (default SI)")
    im.set_defaults(func=_import)


def _bench_commands(sub):
    """Benchmarks (measured numbers, not tests)."""
    b = sub.add_parser("bench", help="benchmarks (not tests)")
    bsub = b.add_subparsers(dest="what", required=True)
    bs = bsub.add_parser("sim", help="compressible model speed vs a solve_ivp Radau reference")
    bs.add_argument("--json", action="store_true")
    bs.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    bs.add_argument("--seconds", type=number(above=0, hi=3600), default=10.0, help="simulated seconds (default 10)")
    bs.add_argument("--ref-seconds", type=number(above=0, hi=3600), default=None,
                    help="simulate only this much with the slow reference (default: all)")
    bs.set_defaults(func=_bench_sim)
    bw = bsub.add_parser("sweep", help="quarter-car frequency sweep time (2 amplitudes x 60 frequencies, Koni)")
    bw.add_argument("--json", action="store_true")
    bw.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    bw.add_argument("--workers", type=number(1, 256, integer=True), default=None,
                    help="processes (default: all cores)")
    bw.set_defaults(func=_bench_sweep)
    bg = bsub.add_parser("log", help="samples per second into MCAP against a protocol's data rate")
    bg.add_argument("--seconds", type=number(above=0, hi=3600), default=5.0)
    bg.add_argument("--json", action="store_true")
    bg.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    bg.set_defaults(func=_bench_log)
    bi = bsub.add_parser("identify", help="dyno identify's time on a full standard sequence (goal < 2 min)")
    bi.add_argument("recording", nargs="?", default=None,
                    help="a standard-sequence recording (default: record one on the virtual rig first, ~4 min)")
    bi.add_argument("--damper", default="koni", help="damper for the recording made first (default koni)")
    bi.add_argument("--json", action="store_true")
    bi.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    bi.set_defaults(func=_bench_identify)
    bd = bsub.add_parser("diagnose", help="dyno diagnose's time on 60 s recorded at 5 kHz (goal < 3 min)")
    bd.add_argument("--seconds", type=number(above=0, hi=3600), default=60.0)
    bd.add_argument("--rate", type=number(above=0, hi=100000), default=5000.0, help="sample rate [Hz] (default 5000)")
    bd.add_argument("--json", action="store_true")
    bd.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    bd.set_defaults(func=_bench_diagnose)
    bl = bsub.add_parser("loop", help="control loop timing in real time against sim-rig in a separate process")
    bl.add_argument("--rate", type=number(above=0, hi=5000), default=1000.0, help="loop rate in Hz (default 1000)")
    bl.add_argument("--seconds", type=number(above=0, hi=3600), default=30.0, help="duration (default 30)")
    bl.add_argument("--json", action="store_true")
    bl.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    bl.set_defaults(func=_bench_loop)


def main(argv=None):
    p = parser()
    args, extra = p.parse_known_args(argv)
    if extra:  # `dyno run` takes name=value anywhere among its options
        if getattr(args, "cmd", None) == "run" and all("=" in e and not e.startswith("-") for e in extra):
            args.params += extra
        else:
            p.error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        return args.func(args)
    except (DamperError, RigError) as e:
        print(f"dyno: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
