"""Shared by several test modules: one shortened standard run on the virtual rig with the
live identification (the longest item of the suite, so it is made once)."""
import subprocess
import sys
from pathlib import Path

import pytest

DYNO = str(Path(sys.executable).parent / "dyno")
SHORT = ["static_points=5", "amplitudes_mm=12.7,6.4,3.2,1.6", "freqs_hz=1,4,16", "targets_c=45"]


@pytest.fixture(scope="session")
def koni_run(tmp_path_factory):
    """(recording, the run's stderr) of `dyno run standard` on the Koni, SHORT settings."""
    out = tmp_path_factory.mktemp("id") / "std.mcap"
    p = subprocess.run([DYNO, "run", "standard", "--out", str(out), *SHORT], capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    return out, p.stderr
