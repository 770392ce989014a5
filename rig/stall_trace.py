"""Where a real-time process was when its control loop stalled. A freeze of the whole
process (the loop and the Modbus pollers stopped together for 60-80 ms under the suite's
load, issue 92) left no thread off its CPU in the scheduler's trace; Python's faulthandler
has a watchdog thread of its own, in C and needing no GIL, that dumps every Python thread's
stack when it is not re-armed in time. The loop re-arms it every few ticks, so a stall
longer than the watchdog's limit leaves the stacks as they were during it, in a file the
fault's message names."""
from __future__ import annotations

import faulthandler
import os
import tempfile

ARM_EVERY = 10  # ticks between re-arming: each costs some 70 us (at 1 kHz every tick would take 7 % of a core)


class StallTrace:
    """Armed by tick(); the stacks go to a file with no name until a stall outlasts
    `limit_s` (plus the ARM_EVERY ticks between arms), which caught() then names: a run
    killed outright leaves nothing behind (mkstemp's file, named from the start, stayed in
    the temporary folder empty). Where the file system has no unnamed files, a named one,
    removed by close() when it stayed empty."""

    def __init__(self, limit_s: float, period_s: float):
        self.path = None
        try:
            fd = os.open(tempfile.gettempdir(), os.O_TMPFILE | os.O_WRONLY, 0o600)
        except (AttributeError, OSError):  # not Linux, or a file system without O_TMPFILE
            fd, self.path = tempfile.mkstemp(prefix=f"dyno-stall-{os.getpid()}-", suffix=".txt")
        self.file = os.fdopen(fd, "w")
        self.timeout = limit_s + ARM_EVERY * period_s
        self.ticks = 0

    def tick(self):
        if self.ticks % ARM_EVERY == 0:
            faulthandler.dump_traceback_later(self.timeout, file=self.file)
        self.ticks += 1

    def caught(self) -> str | None:
        """The file's path once it holds a stall's stacks (named now if it had no name), else None."""
        if self.file.closed:
            return self.path if self.path and os.path.exists(self.path) else None
        if not os.fstat(self.file.fileno()).st_size:
            return None
        if self.path is None:
            # linkat(2) through /proc following the link, as open(2) gives for O_TMPFILE
            # (os.link calls link(2), which does not follow it, unless given a directory)
            try:
                fd, path = tempfile.mkstemp(prefix=f"dyno-stall-{os.getpid()}-", suffix=".txt")
                os.close(fd)
                os.unlink(path)  # the name, reserved, given to the unnamed file
                proc = os.open("/proc/self/fd", os.O_RDONLY)
                try:
                    os.link(str(self.file.fileno()), path, src_dir_fd=proc, follow_symlinks=True)
                finally:
                    os.close(proc)
            except OSError:  # no /proc, a full disk: the stacks stay unnamed; the trip asking must not fail
                return None
            self.path = path
        return self.path

    def close(self) -> str | None:
        """Disarmed: the path of the stacks dumped, or None (an empty named file removed). Again: the same."""
        if not self.file.closed:
            faulthandler.cancel_dump_traceback_later()
            caught = self.caught()
            self.file.close()
            if self.path and not caught:
                os.unlink(self.path)
                self.path = None
        return self.path if self.path and os.path.exists(self.path) else None
