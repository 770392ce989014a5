"""The plan the diagnosis is proven on (proven.toml): prove's recordings, discover's opening
and the envelope its designs keep to, on the virtual cell or a real one alike."""
from __future__ import annotations

import tomllib
from pathlib import Path

PROVEN = Path(__file__).with_name("proven.toml")


def opening() -> tuple[str, dict]:
    """(protocol name, its parameters)."""
    spec = tomllib.loads(PROVEN.read_text())
    return spec["protocol"], spec["params"]
