"""Damper physics library (B. Warner 1996, chapters 3-4)."""
import hashlib
import os
import sys
from pathlib import Path


def _numba_cache_dir() -> str:
    # Compiled kernels read layout constants from other modules (models/kernel.py), but
    # numba's cache only watches each function's own file: an edit elsewhere would reuse
    # stale machine code. Key the whole cache on all model sources instead.
    h = hashlib.sha1()
    for p in sorted(Path(__file__).parent.glob("*.py")):
        h.update(p.read_bytes())
    return str(Path.home() / ".cache" / "dyno" / f"numba-{h.hexdigest()[:12]}")


if "NUMBA_CACHE_DIR" not in os.environ:
    os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
    if "numba" in sys.modules:  # imported before us: make it read the variable again
        sys.modules["numba"].core.config.reload_config()
