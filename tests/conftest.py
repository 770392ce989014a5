"""Shared by several test modules: one shortened standard run on the virtual rig (the
longest item of the suite, so it is made once; the live identification has a run of its
own in test_identify.py)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

# ... and so does one a `dyno` command the tests start draws (pyproject's filterwarnings)
os.environ["DYNO_STRICT_FIGURES"] = "1"
# as `dyno` itself runs (protocols/app/__init__.py), before numpy loads; the suite's two workers
# would otherwise each start a BLAS thread per core
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
assert "numpy" not in sys.modules, "numpy loaded before tests/conftest.py set its threads"

DYNO = str(Path(sys.executable).parent / "dyno")
SHORT = ["static_points=5", "amplitudes_mm=12.7,6.4,3.2,1.6", "freqs_hz=1,4,16", "targets_c=45"]


@pytest.fixture(scope="session")
def koni_run(tmp_path_factory):
    """(recording, the run's stderr) of `dyno run standard` on the Koni, SHORT settings."""
    out = tmp_path_factory.mktemp("id") / "std.mcap"
    p = subprocess.run([DYNO, "run", "standard", "--no-identify", "--out", str(out), *SHORT], capture_output=True,
                       text=True,
                       timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    return out, p.stderr


@pytest.fixture()
def sim_rig():
    """start(config, *extra args) -> the `dyno sim-rig` process, serving once it returns;
    every one started is stopped after the test."""
    import signal
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
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()


# The longest tests (a prove run each: several recordings through the wires and their
# diagnoses) start first, so that the two workers end together instead of one of them
# running a long test alone at the end.
LONGEST = ("test_prove.py::test_prove_runs", "test_diagnose.py::test_prove_finds")


def pytest_collection_modifyitems(items):
    items.sort(key=lambda item: not item.nodeid.split("/")[-1].startswith(LONGEST))
