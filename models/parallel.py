"""Run independent jobs in parallel with a progress bar.

`run_all(fn, jobs)` evaluates fn(job) for every job and returns the results in job order.
It only needs an executor with the `concurrent.futures.Executor` interface (`submit`
returning futures with `result()` and `add_done_callback`), so a distributed executor
(dask.distributed's `client.get_executor()`, mpi4py.futures' `MPIPoolExecutor`, ...)
plugs in where the default process pool sits. fn and the jobs must pickle.
"""
from __future__ import annotations

import os
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor


class Progress:
    """A one-line progress bar with an ETA on a text stream (stderr by default)."""

    def __init__(self, total, label="", stream=None, width=30):
        self.total, self.label, self.width = total, label, width
        self.stream = sys.stderr if stream is None else stream
        self.done = 0
        self.t0 = time.monotonic()
        self._lock = threading.Lock()

    def advance(self, n=1):
        with self._lock:
            self.done += n
            elapsed = time.monotonic() - self.t0
            eta = elapsed / self.done * (self.total - self.done)
            filled = int(self.width * self.done / self.total)
            bar = "#" * filled + "." * (self.width - filled)
            end = "\n" if self.done == self.total else ""
            self.stream.write(f"\r{self.label} [{bar}] {self.done}/{self.total} "
                              f"{elapsed:5.1f} s, ETA {eta:5.1f} s{end}")
            self.stream.flush()


def run_all(fn, jobs, executor=None, workers=None, progress=None, label=""):
    """[fn(job) for job in jobs], in parallel.

    executor: an Executor to submit to (left open); by default a process pool of
    `workers` processes (the machine's cores) is made for the call. workers=1 without an
    executor runs in this process. progress: a stream for the progress bar, True for
    stderr, None for none.
    """
    jobs = list(jobs)
    bar = None
    if progress and jobs:
        bar = Progress(len(jobs), label, None if progress is True else progress)
    try:
        return _run(fn, jobs, executor, workers or os.cpu_count() or 1, bar)
    except BaseException:
        if bar and bar.done < bar.total:
            bar.stream.write("\n")  # an error message after us starts on its own line
        raise


def _run(fn, jobs, executor, workers, bar):
    if executor is None and (workers == 1 or len(jobs) == 1):
        out = []
        for job in jobs:
            out.append(fn(job))
            if bar:
                bar.advance()
        return out
    own = executor is None
    ex = ProcessPoolExecutor(max_workers=min(workers, len(jobs))) if own else executor
    try:
        futures = [ex.submit(fn, job) for job in jobs]
        if bar:
            for f in futures:
                f.add_done_callback(lambda _: bar.advance())
        return [f.result() for f in futures]
    finally:
        if own:
            ex.shutdown(cancel_futures=True)
