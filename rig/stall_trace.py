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
    """Armed by tick(); `path` holds the stacks once a stall outlasted `limit_s` (plus the
    ARM_EVERY ticks between arms); close() removes the file when it stayed empty."""

    def __init__(self, limit_s: float, period_s: float):
        fd, self.path = tempfile.mkstemp(prefix=f"dyno-stall-{os.getpid()}-", suffix=".txt")
        self.file = os.fdopen(fd, "w")
        self.timeout = limit_s + ARM_EVERY * period_s
        self.ticks = 0

    def tick(self):
        if self.ticks % ARM_EVERY == 0:
            faulthandler.dump_traceback_later(self.timeout, file=self.file)
        self.ticks += 1

    def caught(self) -> str | None:
        """The file's path once it holds a stall's stacks, else None."""
        return self.path if os.path.getsize(self.path) else None

    def close(self) -> str | None:
        """Disarmed: the path of the stacks dumped, or None (the empty file removed). Again: the same."""
        if not self.file.closed:
            faulthandler.cancel_dump_traceback_later()
            self.file.close()
            if not self.caught():
                os.unlink(self.path)
        return self.path if os.path.exists(self.path) else None
