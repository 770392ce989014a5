"""Where a real-time process was when its control loop stalled. A freeze of the whole
process (the loop and the Modbus pollers stopped together for 60-80 ms under the suite's
load, issue 92) left no thread off its CPU in the scheduler's trace; Python's faulthandler
has a watchdog thread of its own, in C and needing no GIL, that dumps every Python thread's
stack when it is not re-armed in time. The loop re-arms it every few ticks, so a stall
longer than the watchdog's limit leaves the stacks as they were during it, in a file the
fault's message names, with the scheduler's view of the same time: how long the loop's
thread ran, waited for a CPU, and what the process's other threads and the host's hypervisor
took (a thread's CPU time excludes what the hypervisor stole; a stall it caused is the host's,
not the loop's)."""
from __future__ import annotations

import faulthandler
import os
import tempfile
import time
from dataclasses import dataclass

_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else float("nan")  # /proc/stat's unit
ARM_EVERY = 10  # ticks between re-arming: each costs some 70 us (at 1 kHz every tick would take 7 % of a core)


def _proc(path):
    try:
        return os.open(path, os.O_RDONLY)
    except OSError:  # not Linux: the view says what it can
        return None


@dataclass
class Clocks:
    """One look at where a thread's time goes [s]; nan where the OS does not tell."""
    wall: float
    ran: float  # this thread on a CPU
    process: float  # every thread of the process on a CPU
    waited: float  # this thread ready to run and not run (/proc/thread-self/schedstat)
    stolen: float  # every CPU of the host taken by its hypervisor (/proc/stat's steal)

    @classmethod
    def look(cls, schedstat_fd, stat_fd):
        waited = stolen = float("nan")
        try:
            if schedstat_fd is not None:  # "run_ns wait_ns slices"
                waited = int(os.pread(schedstat_fd, 128, 0).split()[1]) * 1e-9
            if stat_fd is not None:  # "cpu user nice system idle iowait irq softirq steal ..." in clock ticks
                stolen = int(os.pread(stat_fd, 256, 0).split(b"\n", 1)[0].split()[8]) * _TICK_S
        except (OSError, ValueError, IndexError):
            pass
        return cls(time.monotonic(), time.thread_time(), time.process_time(), waited, stolen)

    def since(self, before: Clocks) -> str:
        """Where the time between two looks went, in a phrase."""
        ms = {k: (getattr(self, k) - getattr(before, k)) * 1e3 for k in ("wall", "ran", "process", "waited", "stolen")}
        parts = [f"the loop ran {ms['ran']:.0f} ms"]
        if ms["waited"] == ms["waited"]:
            parts.append(f"waited {ms['waited']:.0f} ms for a CPU")
        parts.append(f"other threads ran {ms['process'] - ms['ran']:.0f} ms")
        if ms["stolen"] == ms["stolen"]:
            parts.append(f"the hypervisor took {ms['stolen']:.0f} ms of the CPUs")
        return f"in the {ms['wall']:.0f} ms since the loop's last look: " + ", ".join(parts)


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
        self.fds = _proc("/proc/thread-self/schedstat"), _proc("/proc/stat")  # opened by the loop's thread
        self.looked = Clocks.look(*self.fds)

    def tick(self):
        if self.ticks % ARM_EVERY == 0:
            faulthandler.dump_traceback_later(self.timeout, file=self.file)
            self.looked = Clocks.look(*self.fds)
        self.ticks += 1

    def where_the_time_went(self) -> str:
        """The scheduler's view since the last arm (the loop's thread calls it)."""
        return Clocks.look(*self.fds).since(self.looked)

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
            for fd in self.fds:
                if fd is not None:
                    os.close(fd)
            if self.path and not caught:
                os.unlink(self.path)
                self.path = None
        return self.path if self.path and os.path.exists(self.path) else None
