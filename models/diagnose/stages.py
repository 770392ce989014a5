"""Where a diagnosis's time goes: wall seconds per stage (each stage's own, a stage inside
another counted once, in the inner) and the share of the cores it kept busy (the CPU time
of this process and the children it reaped, over wall time times cores)."""
from __future__ import annotations

import os
import time
from contextlib import contextmanager

STAGES = ("baseline", "candidates", "p-values", "rivals", "stand-ins", "refit", "final")


class Clock:
    def __init__(self, cores: int = 1):
        self.cores = max(int(cores), 1)
        self.seconds = dict.fromkeys(STAGES, 0.0)
        self._stack = []  # [[stage, start, seconds spent in stages inside it]]
        self._t0, self._cpu0 = time.perf_counter(), self._cpu()

    @staticmethod
    def _cpu():
        t = os.times()
        return t.user + t.system + t.children_user + t.children_system

    @contextmanager
    def stage(self, name: str):
        self._stack.append([name, time.perf_counter(), 0.0])
        try:
            yield
        finally:
            name, start, inner = self._stack.pop()
            spent = time.perf_counter() - start
            self.seconds[name] = self.seconds.get(name, 0.0) + spent - inner
            if self._stack:
                self._stack[-1][2] += spent

    def inner(self, name: str, seconds: float) -> None:
        """Count `seconds` of the stage running as stage `name` inside it (work done
        elsewhere, in the fitting processes, whose share of the wall time is known)."""
        self.seconds[name] = self.seconds.get(name, 0.0) + seconds
        if self._stack:
            self._stack[-1][2] += seconds

    def report(self) -> dict:
        """{"stages_s": {stage: s}, "wall_s": s, "cores_used": share of the cores busy}."""
        wall = time.perf_counter() - self._t0
        busy = (self._cpu() - self._cpu0) / max(wall * self.cores, 1e-9)
        return {"stages_s": dict(self.seconds), "wall_s": wall, "cores": self.cores, "cores_used": busy}
