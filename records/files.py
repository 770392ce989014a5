"""The one rule for what dyno reads and writes, checked before any work starts.

Inputs are regular files: a folder, a FIFO or a device is refused by name (a FIFO would
hang the reader).

Every output:
- never aliases an input: not the same path, not a hard or symbolic link to it, and an
  output folder never holds one;
- is kept if it already exists (a file, or a folder with anything in it) unless the
  caller asked to overwrite it;
- is written to a temporary name beside its target and renamed onto it only when complete,
  so an error, a full disk or Ctrl-C halfway leaves the target as it was.

An output folder is filled the same way: the new files are made in a temporary folder and
moved in when all are written; with overwrite, files of the same names are replaced and
anything else in the folder is left alone.

A recording is written to a partial file beside its target (`.NAME.partial`) and renamed
onto the target once the run has started cleanly (Claim.commit); a lock file (`NAME.lock`,
flock) refuses a second writer of the same target for as long as the first one lives.
"""
from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import stat
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from rig.errors import UsageError
from rig.operator_stop import quiet

TEMP_ROOM = 32  # characters the temporary names add to a file name
LOCK_TRIES = 6  # a lock found held is looked at again for 0.25 s before a second writer is refused


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


def input_file(path: str | Path, what: str = "") -> Path:
    """`path` if it is a regular file that can be opened; RigError naming the problem."""
    path = Path(path)
    label = f"{what} {path}".strip()
    try:
        st = path.stat()
    except FileNotFoundError:
        raise UsageError(f"{label}: no such file") from None
    except OSError as e:
        raise UsageError(f"{label}: cannot read ({_why(e)})") from None
    if stat.S_ISDIR(st.st_mode):
        raise UsageError(f"{label}: a folder, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise UsageError(f"{label}: not a regular file (a FIFO, socket or device is not read)")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{label}: cannot read (permission denied)")
    return path


def existing_files(*values) -> list[Path]:
    """The files named among values (paths, lists of them, and the path in a "name=PATH" or
    "kind:PATH" text): the inputs no output may alias."""
    out = []
    for v in values:
        if isinstance(v, (list, tuple)):
            out += existing_files(*v)
        elif isinstance(v, (str, Path)):
            s = str(v)
            for c in {s, s.partition("=")[2], s.rpartition(":")[2]} - {""}:
                with contextlib.suppress(OSError, ValueError):
                    if Path(c).is_file():
                        out.append(Path(c))
    return out


def _same(a: Path, b: Path) -> bool:
    """a and b are one file: the same path, or links (hard or symbolic) to one inode."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def _name_fits(path: Path, what):
    folder = path.parent if str(path.parent) else Path(".")
    try:
        limit = os.pathconf(folder if folder.exists() else "/", "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    if len(path.name.encode()) + TEMP_ROOM > limit:
        raise UsageError(f"{what} {path.name[:40]}...: file name too long ({len(path.name)} characters; "
                       f"at most {limit - TEMP_ROOM})")


def make_folder(folder: Path, what: str, label: str) -> Path:
    """folder, created if need be; a one-line UsageError naming `what` and `label` if it
    is a file, cannot be created or is not writable."""
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{what} {label}: {folder} is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UsageError(f"{what} {label}: cannot create its folder ({_why(e)})") from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{what} {label}: folder {folder} not writable")


def output_file(path: str | Path, inputs: list = (), overwrite: bool = False, what: str = "--out") -> Path:
    """A file to be written when the work is done, checked now: not an input, kept if it
    exists unless overwrite, its folder created."""
    path = Path(path)
    _name_fits(path, what)
    for i in inputs:
        if i is not None and _same(path, Path(i)):
            raise UsageError(f"{what} {path}: that is an input of this command (an output never replaces one); "
                           f"give another name")
    if path.is_dir():
        raise UsageError(f"{what} {path}: is a folder, not a file")
    if path.exists() and not path.is_file():
        raise UsageError(f"{what} {path}: not a regular file")
    make_folder(path.parent, what, path)
    if not overwrite and (path.exists() or path.is_symlink()):
        raise UsageError(f"{what} {path}: exists; give --overwrite to replace it, or another name "
                       f"(free: {numbered(path).name})")
    return path


def output_folder(path: str | Path, inputs: list = (), overwrite: bool = False, what: str = "--out") -> Path:
    """A folder to be filled when the work is done, checked now: it holds no input, and
    if it holds anything it is kept unless overwrite."""
    path = Path(path)
    _name_fits(path, what)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{what} {path}: exists and is not a folder")
    here = path.resolve()
    for i in inputs:
        if i is not None and here in Path(i).resolve().parents:
            raise UsageError(f"{what} {path}: holds the input {i}; give a folder of its own")
    make_folder(path.parent, what, path)
    if not overwrite and path.is_dir() and any(path.iterdir()):
        raise UsageError(f"{what} {path}: folder exists and is not empty; give --overwrite to replace "
                       f"the files it writes, or another folder")
    if path.is_dir() and not os.access(path, os.W_OK | os.X_OK):
        raise UsageError(f"{what} {path}: folder not writable")
    return path


@contextlib.contextmanager
def written(path: str | Path, what: str = "--out") -> Iterator[Path]:
    """A temporary path beside `path` to write to; it becomes `path` when the block ends
    without an error, and is removed otherwise."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name[:200]}.", suffix=".partial", dir=path.parent)
    os.close(fd)
    try:
        os.chmod(tmp, stat.S_IMODE(path.stat().st_mode) if path.exists() else _default_mode(0o666))
        yield Path(tmp)
        os.replace(tmp, path)
    except OSError as e:
        raise UsageError(f"{what} {path}: cannot write ({_why(e)})") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)


def _default_mode(full):
    """What open() or mkdir() would give: full (0o666, 0o777) less the umask (the temporary
    ones are made 0o600 and 0o700)."""
    mask = os.umask(0)
    os.umask(mask)
    return full & ~mask


def _move_into(src: Path, dst: Path):
    for p in src.iterdir():
        q = dst / p.name
        if p.is_dir() and q.is_dir():
            _move_into(p, q)
        else:
            if q.is_dir():
                shutil.rmtree(q)
            os.replace(p, q)


@contextlib.contextmanager
def filled(path: str | Path, what: str = "--out") -> Iterator[Path]:
    """A temporary folder beside `path` to write into; its files move into `path` when the
    block ends without an error, and it is removed otherwise."""
    path = Path(path)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name[:200]}.", suffix=".partial", dir=path.parent))
    try:
        os.chmod(tmp, _default_mode(0o777))
        yield tmp
        if not path.exists():
            os.rename(tmp, path)
        else:
            _move_into(tmp, path)
    except OSError as e:
        raise UsageError(f"{what} {path}: cannot write ({_why(e)})") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


class Claim:
    """The right to write a recording `target`: the lock, and the partial file it is
    written to.

        claim = Claim(path, overwrite=False)    # RigError if it exists or is being written
        f = claim.open()                        # the partial file, binary
        ...; claim.commit()                     # the run started: the partial becomes the target
        claim.release()                         # abandon() first if never committed
    """

    def __init__(self, target, overwrite=False, what="--out", inputs=()):
        self.target = output_file(target, inputs, overwrite, what)
        self.what = what
        self.overwrite = overwrite
        self.lock_path = self.target.with_name(self.target.name + ".lock")
        self.partial = self.target.with_name(f".{self.target.name}.partial")
        self.committed = False
        with quiet():
            self.lock_fd = self._lock()

    def _lock(self):
        for attempt in range(LOCK_TRIES):
            try:
                fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as e:
                raise UsageError(f"{self.what} {self.target}: cannot create its lock file ({_why(e)})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
                os.close(fd)
                if attempt < LOCK_TRIES - 1:  # a reader looking at the lock holds it for microseconds
                    time.sleep(0.05)
                    continue
                raise UsageError(f"{self.what} {self.target}: another run is writing it (process {holder}; "
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
            raise UsageError(f"{self.what} {self.target}: cannot write ({_why(e)})") from None

    def commit(self):
        """The partial file becomes the target (an open file keeps writing to it)."""
        with quiet():
            self._commit()

    def _commit(self):
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
        with quiet():
            self._release()

    def _release(self):
        if self.lock_fd is None:
            return
        try:
            os.unlink(self.lock_path)
        except OSError:
            pass
        os.close(self.lock_fd)
        self.lock_fd = None


def _lock_of(target) -> Path:
    return Path(target).with_name(Path(target).name + ".lock")


def writer(target: str | Path) -> int | None:
    """The process writing the recording `target`, or None when no live process holds its
    lock. The flock itself says so, not the PID in the file: a PID can be reused by any
    process (PID 1 is always alive), a lock dies with its holder. The lock is taken for a
    moment to look (Claim retries meanwhile) and never left held."""
    lock = _lock_of(target)
    try:
        fd = os.open(lock, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            text = os.pread(fd, 32, 0).decode(errors="replace").strip()
            return int(text) if text.isdigit() else -1  # held, by a process that has not written its PID yet
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def clear_stale_lock(target: str | Path) -> str | None:
    """Remove the lock file of `target` when no live process holds it (its writer died, or
    its PID now names another process); a line saying so, or None when there was none."""
    lock = _lock_of(target)
    try:
        fd = os.open(lock, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return None  # a live writer
        holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
        try:
            if os.path.samestat(os.fstat(fd), os.stat(lock, follow_symlinks=False)):
                os.unlink(lock)
        except OSError:
            return None
        return f"{lock.name}: a stale lock (process {holder} is not writing {Path(target).name}); cleared"
    finally:
        os.close(fd)


def not_being_written(path: str | Path, doing: str = "read") -> Path:
    """`path`, once no live process writes it; RigError naming the writer otherwise. A
    stale lock beside it is cleared, and said so on stderr."""
    pid = writer(path)
    if pid is not None:
        who = f"process {pid}" if pid > 0 else "a process starting up"
        raise UsageError(f"{path}: being recorded now (by {who}); {doing} it once the run has finished "
                       f"(dyno serve shows it live)")
    note = clear_stale_lock(path)
    if note:
        print(f"dyno: {note}", file=sys.stderr)
    return Path(path)
