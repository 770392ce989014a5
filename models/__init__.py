"""Damper physics library (B. Warner 1996, chapters 3-6): the damper model as data
(damper.py, presets/), its equations (physics/), and what is built on them: the
identification (identify/), the diagnosis of missing physics (diagnose/), the quarter car
(quarter_car/) and the thesis validation (validation/)."""
import hashlib
import os
import sys
from pathlib import Path

import records  # noqa: F401 - first: one BLAS thread (records/__init__.py)


# the sources of compiled code: the equations, and the kernels built on them elsewhere
COMPILED = ("physics/*.py", "quarter_car/sim.py", "diagnose/kernels.py", "diagnose/candidates.py", "identify/valves.py")


def _numba_cache_dir() -> str:
    # Compiled kernels read layout constants from other modules (physics/kernel.py), but
    # numba's cache only watches each function's own file: an edit elsewhere would reuse
    # stale machine code. Key the whole cache on the compiled sources instead (not on
    # every model file: editing the diagnosis's reports does not recompile the physics).
    h = hashlib.sha1()
    root = Path(__file__).parent
    for p in sorted(q for pattern in COMPILED for q in root.glob(pattern)):
        h.update(p.read_bytes())
    return str(Path.home() / ".cache" / "dyno" / f"numba-{h.hexdigest()[:12]}")


if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
    if "numba" in sys.modules:  # imported before us: make it read the variable again
        sys.modules["numba"].core.config.reload_config()
