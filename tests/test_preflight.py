"""Pre-flight: every protocol's defaults on every preset are refused before motion or run
without a trip; the forecast's force and gas pressure match what the virtual rig then
measures. The shortened mode runs each plan's hardest moments (preflight.critical: the
segments with the highest predicted force and gas pressure, from rest to rest, the plant
at the temperature they state); spans predicted below half of every limit are not run."""
import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from models.damper import load
from protocols import cell, preflight, runner
from protocols.library import PROTOCOLS
from protocols.plan import MARGIN, ParamError, Plan, Segment, rig_info
from protocols.rehearsal import rehearse
from rig import config
from sim_backend.options import PlantOptions

PRESETS = ("koni", "mechformance", "fox-light", "fox-heavy")
HOLD_S = 3.0  # a wait (a settled force, a temperature) is cut to this: it starts at its temperature
LONG_S = 30.0  # spans that move longer (the low-speed cycles) are quasi-static: not run


def run_span(damper, params, segments, T0):
    peaks = {"force": 0.0, "P_gas": 0.0}

    def sink(drained):
        for k in peaks:
            if len(drained[k][1]):
                peaks[k] = max(peaks[k], float(np.max(np.abs(drained[k][1]))))
    module = SimpleNamespace(NAME="span", check=lambda p, i: [], plan=lambda p, i: iter(segments))
    with cell.direct(config.load("virtual"), damper, PlantOptions(T0=T0)) as c:  # the plant's own trips, not the wires'
        result = runner.run_plan(Plan(module, params), c, sinks=[sink])
    return result, peaks


@pytest.mark.parametrize("damper", PRESETS)
def test_every_protocols_defaults_run_without_a_trip_or_are_refused_before_motion(damper):
    cfg = config.load("virtual")
    info = rig_info(cfg, load(damper))
    L = cfg.limits
    ran = 0
    for name, module in PROTOCOLS.items():
        params = module.Params()
        try:
            module.check(params, info)
            segments = list(module.plan(params, info))
            forecast = preflight.check(segments, info)
        except ParamError as e:  # refused before anything moves, in one line naming why
            assert "\n" not in str(e)
            continue
        assert forecast.force_peak <= MARGIN * L["force_max"] and forecast.gas_peak <= MARGIN * L["gas_pressure_max"]
        if getattr(module, "REHEARSE", False):  # a closed loop: its pre-flight is the whole run, offline
            try:
                rehearse(module, params, cfg, load(damper))
            except ParamError as e:
                assert "\n" not in str(e)
            continue
        for i, j in preflight.critical(segments, forecast):
            span = [dataclasses.replace(s, duration=min(s.duration, HOLD_S), target=None) if s.until else s
                    for s in segments[i:j + 1]]
            f = preflight.forecast(span, info)
            if f.force_peak < 0.5 * L["force_max"] and f.gas_peak < 0.5 * L["gas_pressure_max"]:
                continue
            if sum(s.duration for s in span if not s.until) > LONG_S:
                continue
            temps = [T for s in span for T in preflight.segment_temperatures(s) if T is not None]
            T0 = temps[0] - 1.0 if "until_c" in span[0].params else (temps[0] if temps else None)
            f = preflight.forecast(span, info, T=T0)  # the damper starts at the span's temperature
            x0, mid = span[0].x(0.0), info.x_mid  # the plant starts at mid-stroke: move there slowly
            T = max(abs(x0 - mid) / 0.01, 1e-3)
            span.insert(0, Segment("position", {}, T, lambda t, T=T, x0=x0: mid + (x0 - mid) * min(t / T, 1.0), False))
            result, peaks = run_span(damper, params, span, T0)
            ran += 1
            where = f"{damper} {name} {span[0].name} .. {span[-1].name}"
            assert result.fault is None, f"{where}: {result.fault}"
            # the forecast is what the rig did, or more (it is conservative where the model is:
            # a polytropic gas at rest, cold friction), never much less
            assert 0.6 * f.force_peak <= peaks["force"] <= 1.15 * f.force_peak, (where, peaks, f)
            assert 0.8 * f.gas_peak <= peaks["P_gas"] <= 1.05 * f.gas_peak, (where, peaks, f)
    assert ran >= 2  # each damper meets a limit that matters somewhere


def test_a_sine_too_strong_for_the_cell_is_recorded_at_the_fastest_frequency_that_fits():
    """The Mechformance's rebound is too strong at 12.7 mm and 8 Hz for the 10 kN cell: that
    stroke is recorded at the highest frequency within the margin instead, so the valves'
    high-speed side is still measured; one whose slower substitute is already in the matrix
    is only skipped."""
    from protocols.library import sine_matrix
    info = rig_info(config.load("virtual"), load("mechformance"))
    p = sine_matrix.Params(amplitudes_mm=[12.7], freqs_hz=[4.0, 8.0, 16.0])
    skipped = dict(sine_matrix.check(p, info))
    assert skipped["sine 12.7 mm 8 Hz"].endswith("Hz instead") and "instead" not in skipped["sine 12.7 mm 16 Hz"]
    recorded = [s.params["freq_hz"] for s in sine_matrix.plan(p, info) if s.kind == "sine"]
    assert len(recorded) == 2 and recorded[0] == 4.0 and 4.0 < recorded[1] < 8.0
    f = recorded[1]
    peak = lambda f: info.peak_force(2 * np.pi * f * 0.0127)
    assert peak(f) <= MARGIN * info.force_max < peak(f + 0.1)


def test_the_forecast_and_the_progress_line_speak_the_chosen_units():
    import io
    from protocols.units import Units
    d = load("koni")
    info = rig_info(config.load("virtual"), d)
    module = PROTOCOLS["standard"]
    f = preflight.check(list(module.plan(module.Params(), info)), info)
    metric, us = preflight.summary(f), preflight.summary(f, Units("us"))
    assert " mm, velocity up to " in metric and " mm/s, force up to " in metric and " bar " in metric, metric
    assert " in, velocity up to " in us and " in/s, force up to " in us and " lbf, gas up to " in us and " psi " in us, us
    # a wait on a temperature shows it in F, its target too
    wait = Segment("warm to 60 C", {}, 600.0, lambda t: info.x_mid, record=False, target=("T_body", 333.15))
    stream = io.StringIO()
    line = runner.ProgressLine([wait], "temperature-sweep", stream, Units("us"))
    line.show(0, 1.0, 1.0, {"T_body": SimpleNamespace(value=313.15)}, final=None)
    assert "104.0 F of 140.0 F" in stream.getvalue(), stream.getvalue()
