"""What the benchmarks hide in the virtual plant (hidden.toml, data)."""
from __future__ import annotations

import tomllib
from pathlib import Path

HIDDEN = tomllib.loads(Path(__file__).with_name("hidden.toml").read_text())
