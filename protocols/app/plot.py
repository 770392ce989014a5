"""`dyno plot damper|quarter-car|parametric|simplified`: PNG figures of the model."""
from __future__ import annotations

import os
import sys

from models.damper import DamperError, load

from protocols import cluster
from protocols.app.output import out_dir


def damper(args):
    from protocols.reports.plots import plot_damper
    d = load(args.damper)
    if d.layout == "simplified":
        raise DamperError(f"{d.name}: simplified models have no loops to plot (damping only, eq 6.1/6.2)")
    if not 0 < args.amplitude_mm * 1e-3 <= d.geometry.stroke / 2:
        raise DamperError(f"--amplitude-mm must be in (0, {d.geometry.stroke * 500:.1f}] for {d.name}")
    if any(f <= 0 or f > 100 for f in args.freq):
        raise DamperError("--freq values must be in (0, 100] Hz")
    for p in plot_damper(d, out_dir(args.out), args.amplitude_mm * 1e-3, tuple(args.freq), args.temp):
        print(p)
    return 0


def _freqs(args):
    from models.quarter_car.sweeps import FREQS
    return FREQS if args.freq is None else args.freq


def quarter_car(args):
    from models import quarter_car as qcm
    from protocols.reports import quarter_car as qp
    from models.quarter_car import sweeps
    car = qcm.load(args.car)
    d = load(args.damper)
    T = float(args.temp) + 273.15
    out = out_dir(args.out)
    with cluster.pool(args.cluster, args.workers or os.cpu_count() or 1) as (ex, _):
        fr = sweeps.frequency_response(car, d, [a * 1e-3 for a in args.amplitude_mm], _freqs(args), T=T,
                                       executor=ex, progress=True)
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


def parametric(args):
    from models import quarter_car as qcm
    from protocols.reports import quarter_car as qp
    from models.quarter_car import sweeps
    car = qcm.load(args.car)
    with cluster.pool(args.cluster, args.workers or os.cpu_count() or 1) as (ex, _):
        study = sweeps.parametric_study(car, args.damper, [a * 1e-3 for a in args.amplitude_mm], _freqs(args),
                                        executor=ex, progress=True)
    for p in qp.plot_parametric(study, out_dir(args.out), args.damper):
        print(p)
    return 0


def simplified(args):
    from models import quarter_car as qcm
    from protocols.reports import quarter_car as qp
    from models.quarter_car import sweeps
    with cluster.pool(args.cluster, args.workers or os.cpu_count() or 1) as (ex, _):
        res = sweeps.simplified_comparison(qcm.load(args.car), args.damper, freqs=_freqs(args), executor=ex,
                                           progress=True)
    print(qp.plot_simplified(res, out_dir(args.out) / "simplified-models.png"))
    return 0
