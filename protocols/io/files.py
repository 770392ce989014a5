"""Output files that are never lost, checked before any work starts.

A recording is written to a partial file beside its target (`.NAME.partial`) and renamed
onto the target only once the run has started cleanly (Claim.commit), so a run that fails
at its start leaves an existing file as it was. An existing target is kept unless the
caller asked to overwrite it; a lock file (`NAME.lock`, flock) refuses a second writer of
the same target for as long as the first one lives.

Derived outputs (a model JSON, a report folder) are re-made from recordings, so they may
be replaced; their folders are created, or refused with the reason, before the work.
"""
from __future__ import annotations

import fcntl
import os
from pathlib import Path

from rig.errors import RigError


def _why(e: OSError) -> str:
    return e.strerror or str(e)


def numbered(path: Path) -> Path:
    """path, or path with -2, -3 ... before its suffix: the first that does not exist."""
    path = Path(path)
    k = 2
    out = path
    while out.exists() or out.is_symlink():
        out = path.with_name(f"{path.stem}-{k}{path.suffix}")
        k += 1
    return out


def make_dir(path, what="--out") -> Path:
    """The folder `path`, created with its parents; RigError if it cannot be (a file in the
    way, no permission)."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise RigError(f"{what} {path}: exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise RigError(f"{what} {path}: cannot create the folder ({_why(e)})") from None
    if not os.access(path, os.W_OK):
        raise RigError(f"{what} {path}: folder not writable")
    return path


def writable_file(path, what="--out") -> Path:
    """A file that will be (re)written when the work is done: its folder is created now
    and the target must be a regular file or absent."""
    path = Path(path)
    if path.is_dir():
        raise RigError(f"{what} {path}: is a folder, not a file")
    if path.exists() and not path.is_file():
        raise RigError(f"{what} {path}: not a regular file")
    folder = path.parent
    if folder.exists() and not folder.is_dir():
        raise RigError(f"{what} {path}: {folder} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise RigError(f"{what} {path}: cannot create its folder ({_why(e)})") from None
    if not os.access(folder, os.W_OK):
        raise RigError(f"{what} {path}: folder {folder} not writable")
    return path


class Claim:
    """The right to write `target`: the lock, and the partial file it is written to.

        claim = Claim(path, overwrite=False)    # RigError if it exists or is being written
        f = claim.open()                        # the partial file, binary
        ...; claim.commit()                     # the run started: the partial becomes the target
        claim.release()                         # abandon() first if never committed
    """

    def __init__(self, target, overwrite=False, what="--out"):
        self.target = Path(target)
        self.what = what
        writable_file(self.target, what)
        if not overwrite and (self.target.exists() or self.target.is_symlink()):
            raise RigError(f"{what} {self.target}: exists; give --overwrite to replace it, or another name "
                           f"(free: {numbered(self.target).name})")
        self.overwrite = overwrite
        self.lock_path = self.target.with_name(self.target.name + ".lock")
        self.partial = self.target.with_name(f".{self.target.name}.partial")
        self.lock_fd = self._lock()
        self.committed = False

    def _lock(self):
        while True:
            try:
                fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as e:
                raise RigError(f"{self.what} {self.target}: cannot create its lock file ({_why(e)})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
                os.close(fd)
                raise RigError(f"{self.what} {self.target}: another run is writing it (process {holder}; "
                               f"lock {self.lock_path.name})") from None
            # the lock file may have been removed by its last holder between open and flock
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.lock_path))
            except FileNotFoundError:
                same = False
            if same:
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
                return fd
            os.close(fd)

    def open(self):
        try:
            return open(self.partial, "wb")
        except OSError as e:
            self.release()
            raise RigError(f"{self.what} {self.target}: cannot write ({_why(e)})") from None

    def commit(self):
        """The partial file becomes the target (an open file keeps writing to it)."""
        if self.committed:
            return
        if not self.overwrite:
            try:  # link, not rename: never replaces a file that appeared meanwhile
                os.link(self.partial, self.target)
            except FileExistsError:
                self.target = numbered(self.target)
                os.link(self.partial, self.target)
            os.unlink(self.partial)
        else:
            os.replace(self.partial, self.target)
        self.committed = True

    def abandon(self):
        """Nothing worth keeping was written: remove the partial file."""
        if not self.committed:
            try:
                os.unlink(self.partial)
            except FileNotFoundError:
                pass

    def release(self):
        if self.lock_fd is None:
            return
        try:
            os.unlink(self.lock_path)
        except OSError:
            pass
        os.close(self.lock_fd)
        self.lock_fd = None
