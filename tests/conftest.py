"""Shared by several test modules: one shortened standard run on the virtual plant (made
once; the live identification has a run of its own in test_identify.py), `dyno` commands
run in the test's process, and `dyno sim-rig` processes."""
import contextlib
import io
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

# ... and so does one a `dyno` command the tests start draws (pyproject's filterwarnings)
os.environ["DYNO_STRICT_FIGURES"] = "1"

DYNO = str(Path(sys.executable).parent / "dyno")

# pytest-xdist's workers share the cores: each (and every dyno command it starts) fits on its
# share, unless the caller gave one (the Makefile's run beside the suite: DYNO_FIT_THREADS=1)
if os.environ.get("PYTEST_XDIST_WORKER_COUNT", "").isdigit():
    from workers import threads
    if threads.ENV not in os.environ:
        threads.share(int(os.environ["PYTEST_XDIST_WORKER_COUNT"]))


def dyno(*args):
    """`dyno ARGS` run in this process (the console script's own main: a process each would
    spend most of its time importing); (returncode, stdout, stderr) as a process gives them.
    An exception main lets through fails the test, as a traceback would."""
    from commands import cli
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main([str(a) for a in args])
        except SystemExit as e:  # argparse's usage errors
            code = e.code if isinstance(e.code, int) else 1
    return SimpleNamespace(returncode=code, stdout=out.getvalue(), stderr=err.getvalue())


def recorded(out, protocol, params, damper="koni", effects=(), plain=False, config="virtual", run_info=None):
    """(out, the run's result): `protocol` with `params` {name: value} recorded on the direct
    cell through the run API, for tests that read a recording, not the wires (the standard
    run below: some 18 s this way, many times that through the embedded rig's wires); effects, plain:
    as `dyno run --effect --plain`; config: the rig's (a name or path); run_info: as `dyno run`
    records it (damper_serial, operator, setup.KEY...)."""
    from contextlib import closing

    from protocols import cell, runner
    from protocols.recorded import for_run
    from protocols.library import PROTOCOLS
    from protocols.plan import Plan
    from rig import config as rig_config
    from sim_backend.options import plant_options
    module = PROTOCOLS[protocol]
    plan = Plan(module, module.Params(**params))
    plant = plant_options(damper, list(effects), plain=plain)
    with cell.direct(rig_config.load(config), plant.damper, plant) as c, \
            closing(for_run(out, c, plan, run_info)) as rec:
        result = runner.run_plan(plan, c, [rec])
    assert result.fault is None, result.fault
    return out, result


@pytest.fixture(scope="session")
def koni_run(tmp_path_factory):
    """(recording, the run's result) of the standard protocol on the Koni, shortened."""
    return recorded(tmp_path_factory.mktemp("id") / "std.mcap", "standard",
                    {"static_points": 5, "amplitudes_mm": [12.7, 6.4, 3.2, 1.6], "freqs_hz": [1.0, 4.0, 16.0],
                     "targets_c": [45.0]})


@pytest.fixture(scope="session")
def prove_keep(tmp_path_factory):
    """A `dyno prove --keep` folder the prove tests share: the null of seed 0, which each
    measures its rows against, is recorded and diagnosed once (the tests share a worker)."""
    return tmp_path_factory.mktemp("prove-keep")


@pytest.fixture()
def sim_rig():
    """start(config, *extra args) -> the `dyno sim-rig` process, serving once it returns;
    every one started is stopped after the test."""
    import time
    procs = []

    def start(cfg, *extra):
        p = subprocess.Popen([DYNO, "sim-rig", "--config", str(cfg), "--seconds", "120", *extra],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(p)
        t0, lines = time.monotonic(), []
        while time.monotonic() - t0 < 120:
            line = p.stdout.readline()
            if not line:
                break
            lines.append(line)
            if "serving" in line:
                return p
        raise AssertionError("sim-rig did not start:\n" + "".join(lines))
    yield start
    for p in procs:
        stop(p)


def stop(p):
    """Stop a `dyno sim-rig` process: SIGTERM, then a kill. A test whose rig is done stops it
    before its analyses: while it serves, its plant steps in real time on a third of a core."""
    import signal
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()


def operator_stopped(p):
    """The stderr of a `dyno` process given SIGTERM, once it has ended as an operator's stop
    must: exit 130, no traceback."""
    import signal
    p.send_signal(signal.SIGTERM)
    try:
        code = p.wait(timeout=60)
    finally:
        p.kill()
    err = p.stderr.read()
    assert code == 130 and "Traceback" not in err, err
    return err


# The longest tests (prove runs: recordings through the wires and their diagnoses; the
# real MR recording's diagnosis) start first, after the tests against the wall clock, so
# that the two workers end together instead of one of them running a long test alone at the end. The Makefile gives
# --no-loadscope-reorder: pytest-xdist would otherwise start the groups with the most tests
# first, and the prove runs then met a hundred short tests that each start a `dyno` process,
# which more than doubled them (the wired prove pair: 151-167 s against 82 s).
LONGEST = ("test_prove.py::test_prove_runs", "test_diagnose.py::test_prove_open", "test_diagnose.py::test_prove_finds",
           "test_outside_data.py::test_the_mr_recording", "test_outside_data.py::test_a_declared_coil")


# session fixtures made once per worker: every test using one goes to the same worker (a
# test left out of the group made the 50 s standard run again on the other worker)
SHARED = ("koni_run",)

# One worker runs the tests against the wall clock first, one after another (about half a
# core for 150 s: the other worker's tests and the Makefile's other-kernel run beside them),
# then the prove runs. A prove run's recording hands every tick from thread to thread through
# the embedded rig's emulators; beside the wall-clock tests' SCHED_FIFO threads it took twice
# its time. The prove tests share their null run (the prove_keep fixture), made once on this worker.
SERIAL = "wall clock, then prove"


def _order(item):
    if item.get_closest_marker("realtime"):
        return -1
    return next((i for i, n in enumerate(LONGEST) if item.nodeid.split("/")[-1].startswith(n)), len(LONGEST))


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups
def pytest_collection_modifyitems(items):
    for item in items:
        if item.get_closest_marker("realtime") or "prove_keep" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group(SERIAL))
        for name in SHARED:
            if name in getattr(item, "fixturenames", ()) and not item.get_closest_marker("xdist_group"):
                item.add_marker(pytest.mark.xdist_group(name))
    items.sort(key=_order)
