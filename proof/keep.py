"""Results of long runs kept on disk (`dyno prove --keep DIR`): each task's result under a
name made of the task and of the code that computed it. A proof stopped part-way (hours
of `make results`) goes on where it stopped, and proofs that share a task (the null of a
seed, which every row is measured against) compute it once. A change to the code gives
every task a new name: nothing computed by other code is reused."""
from __future__ import annotations

import functools
import hashlib
import os
import pickle
import tempfile
from pathlib import Path

from rig.errors import UsageError
from records.files import make_folder

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("models", "protocols", "sim_backend", "rig")  # what a result depends on: code and data files
KINDS = (".py", ".toml", ".json", ".dbc")


@functools.cache
def code() -> str:
    """A digest of the sources and data files results are computed by."""
    h = hashlib.sha1()
    for p in sorted(q for d in SOURCES for q in (ROOT / d).rglob("*") if q.suffix in KINDS and q.is_file()):
        h.update(str(p.relative_to(ROOT)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def folder(path, what="--keep") -> Path:
    """The folder results are kept in, created if need be (a one-line error if it cannot be)."""
    if not str(path).strip():
        raise UsageError(f"{what}: give a folder to keep the runs' results in")
    path = Path(path)
    make_folder(path, what, path)
    return path


def _path(where: Path, task) -> Path:
    return where / f"{hashlib.sha1(repr((code(), task)).encode()).hexdigest()[:20]}.pkl"


def load(where: Path, task):
    """The result kept for task, or None."""
    try:
        return pickle.loads(_path(where, task).read_bytes())
    except (OSError, EOFError, pickle.UnpicklingError):  # none yet, or cut short: computed again
        return None


def save(where: Path, task, result) -> None:
    """Keeps result for task; whole or not at all (a stop mid-write leaves no file)."""
    fd, tmp = tempfile.mkstemp(dir=where, suffix=".tmp")
    with os.fdopen(fd, "wb") as f:
        pickle.dump(result, f)
    os.replace(tmp, _path(where, task))
