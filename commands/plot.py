"""`dyno plot damper|quarter-car|parametric|simplified`: PNG figures of the model."""
from __future__ import annotations

import functools
import sys
from pathlib import Path

from workers import threads
from models.damper import DamperError, load

from commands.arguments import FOLDER, cluster_option, number, overwrite, writes


def add(sub):
    """The `dyno plot` command's arguments."""
    pl = sub.add_parser("plot", help="write plots as PNG")
    plsub = pl.add_subparsers(dest="what", required=True)
    pd = plsub.add_parser("damper", help="loops, composite curve, temperature and pressure plots")
    pd.add_argument("damper", help="preset name (koni, mechformance, fox-light, fox-heavy) or FILE.json")
    writes(pd, "--out", FOLDER, required=True, help="output directory")
    pd.add_argument("--amplitude-mm", type=number(), default=12.7, help="sine amplitude (default 12.7)")
    pd.add_argument("--freq", type=number(), nargs="+", default=[1, 2, 4, 8, 16], help="frequencies in Hz")
    pd.add_argument("--temp", type=number(), default=94.0, help="damper temperature in C (default 94)")
    overwrite(pd, "the figures in --out")
    pd.set_defaults(command="plot:damper")
    for name, helptext, command in (
            ("quarter-car", "frequency and step responses of a quarter car (6.2)", "plot:quarter_car"),
            ("parametric", "parametric study of one damper (6.3)", "plot:parametric"),
            ("simplified", "simplified models I and II against the comprehensive model (6.4)",
             "plot:simplified")):
        q = plsub.add_parser(name, help=helptext)
        q.add_argument("--damper", default="koni", help="preset name or FILE.json (default koni)")
        q.add_argument("--car", default="race-car" if name == "parametric" else "simulator",
                       help="quarter-car preset (simulator, simulator-9kg, race-car) or FILE.json")
        writes(q, "--out", FOLDER, required=True, help="output directory")
        overwrite(q, "the figures in --out")
        q.add_argument("--freq", type=number(), nargs="+", default=None,
                       help="excitation frequencies in Hz (default 1.25-20 in 0.25 Hz steps)")
        if name != "simplified":
            q.add_argument("--amplitude-mm", type=number(), nargs="+", default=[3.2, 12.7],
                           help="road amplitudes in mm (default 3.2 12.7)")
        if name == "quarter-car":
            q.add_argument("--temp", type=number(), default=90.0, help="damper temperature in C (default 90)")
        q.add_argument("--workers", type=number(1, 256, integer=True), default=None,
                       help="processes (default: the cores dyno may run on)")
        cluster_option(q)
        q.set_defaults(command=command)


def _figures(fn):
    """fn(args, folder) -> [PNG paths] drawn into --out: the folder is checked before the work
    and filled once every figure is drawn (records/files.py)."""
    from records.files import existing_files, filled, output_folder
    @functools.wraps(fn)
    def run(args):
        out = output_folder(args.out, existing_files(args.damper, getattr(args, "car", None)), args.overwrite)
        with filled(out) as folder:
            pngs = fn(args, folder)
        for p in pngs:
            print(out / Path(p).name)
        return 0
    return run


@_figures
def damper(args, folder):
    from views.reports.plots import plot_damper
    d = load(args.damper)
    if d.layout == "simplified":
        raise DamperError(f"{d.name}: simplified models have no loops to plot (damping only, eq 6.1/6.2)")
    if not 0 < args.amplitude_mm * 1e-3 <= d.geometry.stroke / 2:
        raise DamperError(f"--amplitude-mm must be in (0, {d.geometry.stroke * 500:.1f}] for {d.name}")
    if any(f <= 0 or f > 100 for f in args.freq):
        raise DamperError("--freq values must be in (0, 100] Hz")
    return plot_damper(d, folder, args.amplitude_mm * 1e-3, tuple(args.freq), args.temp)


def _freqs(args):
    from models.quarter_car.sweeps import FREQS
    return FREQS if args.freq is None else args.freq


@_figures
def quarter_car(args, out):
    from protocols import cluster
    from models import quarter_car as qcm
    from views.reports import quarter_car as qp
    from models.quarter_car import sweeps
    car = qcm.load(args.car)
    d = load(args.damper)
    T = float(args.temp) + 273.15
    with cluster.pool(args.cluster, args.workers or threads.cores()) as (ex, _):
        fr = sweeps.frequency_response(car, d, [a * 1e-3 for a in args.amplitude_mm], _freqs(args), T=T,
                                       executor=ex, progress=True)
    pngs = [qp.plot_frequency_response(fr, out / f"frequency-response-{d.name}.png")]
    if d.layout != "simplified":
        steps = [(A, *sweeps.step_response(car, d, A, T=T)) for A in (0.025, -0.025, 0.0508)]
        pngs.append(qp.plot_steps(steps, out / f"step-response-{d.name}.png",
                                  f"Quarter car '{car.name}' with {d.name} at {args.temp:g} C: road steps"))
    for i, A in enumerate(fr.amplitudes):
        on_stops = fr.freqs[fr.values["stop_fraction"][i] > 0]
        if on_stops.size:
            print(f"note: at {A * 1e3:.1f} mm the damper reaches its stops between {on_stops[0]:.2f} and "
                  f"{on_stops[-1]:.2f} Hz", file=sys.stderr)
    return pngs


@_figures
def parametric(args, folder):
    from protocols import cluster
    from models import quarter_car as qcm
    from views.reports import quarter_car as qp
    from models.quarter_car import sweeps
    car = qcm.load(args.car)
    with cluster.pool(args.cluster, args.workers or threads.cores()) as (ex, _):
        study = sweeps.parametric_study(car, args.damper, [a * 1e-3 for a in args.amplitude_mm], _freqs(args),
                                        executor=ex, progress=True)
    return qp.plot_parametric(study, folder, args.damper)


@_figures
def simplified(args, folder):
    from protocols import cluster
    from models import quarter_car as qcm
    from views.reports import quarter_car as qp
    from models.quarter_car import sweeps
    with cluster.pool(args.cluster, args.workers or threads.cores()) as (ex, _):
        res = sweeps.simplified_comparison(qcm.load(args.car), args.damper, freqs=_freqs(args), executor=ex,
                                           progress=True)
    return [qp.plot_simplified(res, folder / "simplified-models.png")]
