"""Hardware-in-the-loop: the car stepped on a force from outside, the compensators on a
synthetic actuator, the road specs, and `dyno run hil` on the embedded virtual rig (the
coupling against the reference, the guard, the pre-flight's refusals)."""
import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from rerun.chunk import RrdReader

from models.damper import load as load_damper
from models.damper import to_dict
from models.quarter_car import load as load_car
from models.quarter_car.road import faded
from models.quarter_car.sim import CarStepper, simulate
from records.reader import load_recording
from protocols.library import roads
from protocols.plan import ParamError
from rig.compensation import Adaptive, NoCompensation, Polynomial, fit, kernels
from tests.conftest import dyno

DYNO = str(Path(sys.executable).parent / "dyno")
H = 1e-3


def test_the_stepper_is_the_simulation_one_step_at_a_time():
    qc = load_car("simulator")
    t = np.arange(0.0, 1.0, H)
    y = faded(t, 0.01 * np.sin(2 * np.pi * 3 * t), 0.2)
    damper = lambda x, v: 2000.0 * v + 300.0
    ref = simulate(qc, damper, t, y, F_static=300.0, x_install=0.04, stroke=0.08)
    car = CarStepper(qc, t, y, F_static=300.0, x_install=0.04, stroke=0.08)
    x, v, _ = car.motion()
    while not car.done:
        x, v, _ = car.step(damper(x, v))
    r = car.result()
    assert np.array_equal(r.damper_x, ref.damper_x) and np.array_equal(r.tire_force, ref.tire_force)


def _actuator(commands, tau=0.004, delay=1):
    """A first-order servo (time constant tau [s]) behind `delay` ticks: what it reaches."""
    x, out = commands[0], []
    for k in range(len(commands)):
        c = commands[max(k - delay, 0)]
        x += (1 - np.exp(-H / tau)) * (c - x)
        out.append(x)
    return np.array(out)


@pytest.mark.parametrize("rate_hz", [100.0, 333.0, 1000.0, 1234.5, 5000.0, 10000.0])
def test_the_smoothing_kernels_are_scipys_savitzky_golay_to_the_last_bit(rate_hz):
    from scipy.signal import savgol_coeffs
    h = 1.0 / rate_hz
    n = max(5, int(round(0.015 / h)) | 1)
    for d, k in enumerate(kernels(n, h)):
        assert np.array_equal(k, savgol_coeffs(n, 3, deriv=d, delta=h)), (n, d)


def test_fit_finds_the_lag_of_a_first_order_servo():
    t = np.arange(0.0, 2.0, H)
    c = 0.04 + 1e-3 * sum(np.sin(2 * np.pi * f * t + i) for i, f in enumerate((3, 7, 13, 19)))
    m = _actuator(c)
    coef, _ = fit(c, m, np.zeros_like(c), H, with_force=False)
    # 4 ms lag + one tick of transport, less the tick fit() aligns by: about 4 ms
    assert 0.0035 < coef[1] / coef[0] < 0.0055


def _track(comp):
    """J2 of a 4 ms first-order servo driven through `comp` to follow a 5 Hz sine."""
    t = np.arange(0.0, 4.0, H)
    target = 0.04 + 0.005 * np.sin(2 * np.pi * 5 * t) * np.minimum(t / 0.5, 1.0)
    v = np.gradient(target, H)
    a = np.gradient(v, H)
    servo, reached = 0.04, []
    for k in range(len(t) - 1):
        x_c = comp.command(target[k + 1], v[k + 1], a[k + 1], 0.0)
        comp.observe(x_c, servo, 0.0)
        servo += (1 - np.exp(-H / 0.004)) * (x_c - servo)
        reached.append(servo)
    err = np.array(reached[1000:]) - target[1001:]
    return np.sqrt(np.mean(err ** 2)) / np.std(target[1001:])


# the polynomial told the lag; the adaptive one started far from it, learning it online
@pytest.mark.parametrize("comp, delay", [(Polynomial, 0.004), (Adaptive, 0.001)])
def test_a_compensator_tracks_a_lagging_servo_better_than_none(comp, delay):
    none = _track(NoCompensation(0.0, H))
    assert none > 0.1  # 4 ms at 5 Hz: the sine's phase is 7 degrees late
    assert _track(comp(delay, H)) < 0.3 * none


@pytest.mark.parametrize("spec, message", [
    ("bump:5", "unknown kind 'bump'"), ("sine:0:5", "hz must be above 0"), ("sweep:20:1:5", "must rise"),
    ("iso8608:Z:50", "class is one of A-H"), ("step:x", "not all numbers"), ("file:/nonexistent.csv", "no such file"),
])
def test_a_bad_road_is_named(spec, message):
    with pytest.raises(ParamError, match=message):
        roads.parse(spec, 1000.0)


def test_each_road_starts_and_ends_at_rest(tmp_path):
    csv = tmp_path / "road.csv"
    csv.write_text("t_s,height_mm\n0,3\n0.5,8\n1.0,3\n")
    for spec in ("step:20", "sine:4:5", "sweep:1:20:5", "iso8608:C:50:3", f"file:{csv}"):
        r = roads.parse(spec, 1000.0)
        assert r.y[0] == pytest.approx(0.0, abs=1e-9) and r.v[-1] == 0.0, spec
        assert np.allclose(np.diff(r.t), 1e-3)


def _run(tmp_path, *args, process=False):
    """`dyno run hil --out hil.mcap ARGS` in this process, or (process) as its own."""
    out = tmp_path / "hil.mcap"
    if not process:
        return dyno("run", "hil", "--out", out, *args), out
    p = subprocess.run([DYNO, "run", "hil", "--out", str(out), *args], capture_output=True, text=True, timeout=300)
    return p, out


def _result(path):
    _, events, _ = load_recording(path)
    return next(e.params for e in events if e.kind == "result")


def test_the_loop_reproduces_the_reference_with_a_known_damper_model(tmp_path):
    """The plant's damper is the model (its friction in the plant's pre-sliding form), so
    what the car does around the rig is what it does around the model: within the goal."""
    d = to_dict(load_damper("koni"))
    d["friction"]["x_stick"] = 1e-4  # sim_backend/plant.toml [frame] friction_x_stick
    model = tmp_path / "koni-dahl.json"
    model.write_text(json.dumps(d))
    p, out = _run(tmp_path, "--damper", str(model), "--road", "iso8608:C:50:4")
    assert p.returncode == 0, p.stderr[-2000:]
    m = _result(out)
    assert m["j2"] < 0.02 and 3.0 < m["probe_delay_ms"] < 6.0, m
    for k in ("body_acc_nrmse", "travel_nrmse", "tire_load_nrmse"):
        assert m[k] < 0.03, (k, m)
    ch, _, _ = load_recording(out)
    assert {"hil.x_target", "hil.error", "hil.ref.body_acc", "hil.tire_load"} <= set(ch)
    assert "J2" in p.stderr and "pre-flight (the run against the virtual plant)" in p.stderr
    r = dyno("report", str(out), "--out", str(tmp_path / "rep"))
    assert r.returncode == 0, r.stderr
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "hil-tracking.png" in page and "hil-responses.png" in page and "J2 [%]" in page
    assert "J2: how far the damper missed" in page  # the measures said where they are shown
    # in a team's units, travel from static equilibrium (it starts at rest: zero)
    from views.reports import hil as hil_page
    from protocols.units import Units
    fig = hil_page._responses(ch, Units("us"))
    labels = [a.get_ylabel() for a in fig.axes if a.get_ylabel()]
    assert labels == ["body acceleration [g]", "travel from static [in]", "tire load [lbf]"], labels
    travel = fig.axes[2].lines[0].get_ydata()
    assert travel[0] == 0.0 and 0.1 < np.max(np.abs(travel)) < 2.0  # inches


def test_an_unstable_loop_trips_the_guard_and_stops_safely(tmp_path):
    """A conditioning lag the damper model does not know (20 ms on the LVDT): the rehearsal
    passes, the cell's loop over-corrects, and the guard stops it."""
    p, out = _run(tmp_path, "--road", "sine:3:10", "--effect", "sensor_delay=0.02")
    assert p.returncode == 1 and "hil guard" in p.stderr and "Traceback" not in p.stderr, p.stderr[-2000:]
    _, events, _ = load_recording(out)
    kinds = [e.kind for e in events]
    assert "fault" in kinds and kinds[-1] == "run_end"
    r = dyno("report", str(out), "--out", str(tmp_path / "rep"))
    assert r.returncode == 0 and (tmp_path / "rep" / "hil-tracking.png").exists(), r.stderr  # where it diverged


@pytest.mark.parametrize("args, message", [
    (["compensator=polynomial", "delay_ms=40"], "pre-flight: the run against the virtual plant"),
    (["--road", "step:80"], "outside the stroke limits"),
    (["--compensator", "smith"], "compensator: unknown 'smith'"),
    (["--car", "truck"], "unknown quarter-car 'truck'"),
])
def test_the_pre_flight_refuses_before_anything_moves(tmp_path, args, message):
    p, out = _run(tmp_path, "--road", "sine:3:10", *args)
    assert p.returncode == 2 and message in p.stderr and not out.exists(), p.stderr[-2000:]


def test_the_live_view_shows_the_car(tmp_path):
    """`dyno run hil --rrd`: the car's channels and the tracking error reach the view."""
    rrd = tmp_path / "hil.rrd"
    p, out = _run(tmp_path, "--road", "sine:3:10", "--rrd", str(rrd), process=True)  # the viewer's file closed with it
    assert p.returncode == 0, p.stderr[-2000:]
    # read as rerun reads it: the file is LZ4-compressed, so a name can be a back-reference
    # to an earlier one's bytes ("temperatures [C]" after "pressures [bar]") and a search of
    # the raw bytes missed it now and then
    reader = RrdReader(rrd)
    rows = {}
    for chunk in reader.stream():
        if not chunk.is_static:
            rows[chunk.entity_path] = rows.get(chunk.entity_path, 0) + chunk.num_rows
    for entity in ("hil.x_target", "hil.error", "hil.body_acc", "hil.tire_load", "hil.ref.body_acc", "T_body"):
        assert rows.get(f"/channels/{entity}", 0) > 0, (entity, rows)
    views = [name for store in reader.blueprints() for chunk in reader.stream(store=store)
             if "ViewBlueprint:display_name" in (batch := chunk.to_record_batch()).schema.names
             for name in batch.column("ViewBlueprint:display_name").to_pylist()[0]]
    for view in ("tracking error [mm]", "car: body acceleration [m/s^2]", "car: tire load [N]", "temperatures [C]",
                 "force [N]"):
        assert view in views, (view, views)


def _target_csv(tmp_path):
    """A damper history to replay: the race car's suspension travel on an ISO 8608 class C
    road (content to 20 Hz), about its installed position, in mm."""
    from models.quarter_car.sim import run
    r = roads.parse("iso8608:C:50:3", 1000.0)
    ref = run(load_car("race-car"), "koni", r.t, r.y, r.v, T=293.15)
    path = tmp_path / "target.csv"
    np.savetxt(path, np.c_[r.t, 1e3 * (ref.damper_x - ref.damper_x[0])], delimiter=",",
               header="t_s,displacement_mm", comments="")
    return path


def test_replay_converges_on_the_target(tmp_path):
    """Each iteration's drive is corrected from the last one's error through the rig's
    measured response: the damper follows the history within 1 % in at most 5 iterations."""
    out = tmp_path / "replay.mcap"
    p = dyno("run", "replay", "--target", _target_csv(tmp_path), "--iterations", "3", "--out", out)
    assert p.returncode == 0, p.stderr[-2000:]
    _, events, _ = load_recording(out)
    errors = [e.params["nrmse"] for e in events if e.kind == "result"]
    assert len(errors) == 3 and errors[0] > 0.05 and errors[-1] < 0.01 and errors[-1] < errors[0] / 5, errors
    ch, _, _ = load_recording(out)
    assert {"replay.drive", "replay.target", "replay.error"} <= set(ch)
    # every iteration's ticks are kept, not only the last one's
    t = ch["replay.error"][0]
    spans = [(e.t, e.segment) for e in events if e.kind in ("segment_start", "segment_end")]
    for i in range(3):
        a, b = (t_ for t_, name in spans if name == f"replay iteration {i}")
        assert np.sum((t >= a) & (t < b)) > 0.99 * (b - a) * 1000, i
    r = dyno("report", str(out), "--out", str(tmp_path / "rep"))
    page = (tmp_path / "rep" / "index.html").read_text()
    assert r.returncode == 0 and "replay.png" in page, r.stderr
    # the error of each iteration, as a table beside the figure
    assert "NRMS error [%]" in page and f"{100 * errors[-1]:.3f}" in page
    # and without a stall's catch-up: on the simulated clock no tick is late, the two are one
    undisturbed = [e.params["nrmse_undisturbed"] for e in events if e.kind == "result"]
    assert undisturbed == errors and "undisturbed [%]" in page


@pytest.mark.parametrize("args, message", [
    ([], "target: give the displacement history"),
    (["--target", "/nonexistent.csv"], "no such file"),
    (["--iterations", "0", "--target", "TARGET"], "iterations: 1 to 50"),
])
def test_replay_refuses_bad_input_in_one_line(tmp_path, args, message):
    args = [str(_target_csv(tmp_path)) if a == "TARGET" else a for a in args]
    out = tmp_path / "r.mcap"
    p = dyno("run", "replay", *args, "--out", out)
    assert p.returncode == 2 and message in p.stderr and len(p.stderr.strip().splitlines()) <= 2, p.stderr
    assert not out.exists()


def test_a_replay_iteration_s_error_is_also_given_without_a_stall_s_catch_up():
    """Issue 92: a stall of the control loop (its process frozen 62 ms over the wires) leaves
    the actuator catching up for about 20 ms; those ticks are the controller's: the iteration's
    error is also given without them."""
    from protocols.library import replay
    h = 1e-3
    t = np.arange(2000) * h
    target = 0.1 + 0.01 * np.sin(2 * np.pi * 2 * t)
    learning = replay.Learning(replay.Params(target="x.csv", iterations=2), target, h)
    it = learning.iteration(0)
    held = None
    for k in range(len(t)):
        if 1000 <= k < 1060:  # the loop frozen: no tick, the setpoint held
            held = target[999]
            continue
        catch_up = held is not None and k < 1020 + 60  # the actuator still where the freeze left it
        x = held + (target[k] - held) * (k - 1060) / 20 if catch_up else target[k]
        it.setpoint(t[k], t[k], {"x": SimpleNamespace(value=x)})
    _, m = it.after()
    assert m["nrmse"] > 0.05 and m["nrmse_undisturbed"] < 1e-12, m
    assert "without the ticks a stall of the control loop disturbed" in replay.summary(m)


def test_a_closed_loop_says_when_the_control_loop_stalled_through_it():
    """Ticks within 10 ms after a gap of the loop are counted as stalled; a share over the
    bound is said beside a replay's or a car's measures, and a replay iteration too sparse
    to learn from says so."""
    from protocols import plan
    from protocols.library import hil, replay
    h = 1e-3
    ts = np.arange(1000) * h
    assert plan.stalled(ts, h) == 0.0 and plan.stalled([], h) == 0.0
    gapped = np.r_[ts[:500], ts[505:]]  # one stall of 5 ticks: the 10 ticks after it are disturbed
    assert plan.stalled(gapped, h) == pytest.approx(10 / len(gapped))
    calm = {"nrmse": 0.012, "samples": 3990, "stalled": 0.13, "learned_from": True}
    assert replay.summary(calm) == "NRMS error 1.20 % of the target's motion"
    rough = {**calm, "stalled": 0.31, "learned_from": False}
    assert "31 % of its ticks just after a stall" in replay.summary(rough)
    assert "not learned from" in replay.summary(rough)
    car = {"j2": 0.02, "delay_ms": 3.0, "probe_delay_ms": 3.1, "residual_delay_ms": 0.1, "T_c": 25.0,
           "body_acc_nrmse": 0.05, "travel_nrmse": 0.04, "tire_load_nrmse": 0.03}
    assert "stall" not in hil.summary({**car, "stalled": 0.13})
    assert hil.summary({**car, "stalled": 0.25}).endswith("25 % of its ticks just after a stall of the control "
                                                         "loop: this host did not keep real time)")


def _car_loop(stall_at=None, stall_ticks=0, stuck_at=None):
    """The road segment's loop (iso8608 class C, the race car) around a 4 ms first-order
    servo and a 3 kN s/m damper, tick by tick: the control loop asleep for stall_ticks at
    stall_at [s] (the servo holding its last command), the servo stuck from stuck_at [s].
    The time [s] the guard stopped it, else None."""
    from protocols.library.hil import CarLoop, Params
    from protocols.plan import RigInfo
    from rig.errors import RigError
    x_mid = 0.04
    rig = RigInfo(x_mid=x_mid, x_min=0.0, x_max=0.08, v_max=1.0, f_max=30.0, force_max=1e4, T_max=400.0,
                  T_ambient=293.15, damper=SimpleNamespace(geometry=SimpleNamespace(stroke=0.08)))
    road = roads.parse("iso8608:C:50:3", 1000.0)
    loop = CarLoop(Params(car="race-car", delay_ms=4.0), rig, load_car("race-car"), road)
    servo, last, command = x_mid, x_mid, x_mid
    for k in range(len(road.t)):
        t = k * H
        stuck = stuck_at is not None and t >= stuck_at
        servo += 0.0 if stuck else (1 - np.exp(-H / 0.004)) * (command - servo)
        v = (servo - last) / H
        last = servo
        if stall_at is not None and stall_at <= t < stall_at + stall_ticks * H:
            continue  # asleep: no reading taken, the command held
        readings = {"x": SimpleNamespace(value=servo), "force": SimpleNamespace(value=300.0 + 3000.0 * v)}
        try:
            command = loop.setpoint(t, t, readings)
        except RigError:
            return t
    return None


def test_a_stall_of_the_host_does_not_trip_the_guard_and_a_stuck_actuator_does():
    """CI's failure of 2026-12-07: one 17 ms stall of the control loop over the wires, the car
    4.2 mm on while the actuator held its command, and the guard stopped a loop that
    tracked. The stall's lag is allowed while the servo takes it back; a servo that stops
    following trips the guard within its hold time."""
    assert _car_loop() is None
    # at 1.5 s the road's damper speed is ~0.2 m/s: 25 ms of it is 5 mm, over twice the guard
    for at in (1.0, 1.5, 2.0, 2.5):
        assert _car_loop(stall_at=at, stall_ticks=25) is None, at
    tripped = _car_loop(stuck_at=1.5)
    assert tripped is not None and tripped - 1.5 < 0.1, tripped
    tripped = _car_loop(stall_at=1.5, stall_ticks=25, stuck_at=1.5)
    assert tripped is not None and tripped - 1.5 < 0.1, tripped
