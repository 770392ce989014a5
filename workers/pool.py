"""Run independent jobs in parallel with a progress bar.

`run_all(fn, jobs)` evaluates fn(job) for every job and returns the results in job order.
It only needs an executor with the `concurrent.futures.Executor` interface (`submit`
returning futures with `result()`), so a distributed executor
(dask.distributed's `client.get_executor()`, mpi4py.futures' `MPIPoolExecutor`, ...)
plugs in where the default process pool sits. fn and the jobs must pickle.

A job that raises is run once more (a worker's passing trouble: memory, a lost
connection) and, if it fails again, stops the call with TaskFailed naming it; a job whose
worker process died is re-run by a Dask executor itself.
"""
from __future__ import annotations

import contextlib
import multiprocessing
import os
import platform
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool

from workers import threads


class TaskFailed(RuntimeError):
    """A job failed twice; the message names it."""


# glibc's mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def heap_for_arrays():
    """Large arrays from the heap again in a process started with MALLOC_TRIM_THRESHOLD_ set,
    as a Dask nanny starts its workers (to hand memory back to the OS). Setting it switches
    off glibc's rising mmap threshold: every array over 128 kB is then mapped and unmapped
    anew and each of its pages faults in; a diagnosis took 65 s so against 21 s, two thirds
    of it in the kernel. The thresholds set are the ceiling glibc's own rule rises to: 32 MiB,
    trimming at twice that."""
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ or platform.libc_ver()[0] != "glibc":
        return
    import ctypes
    libc = ctypes.CDLL(None)
    libc.mallopt(_M_MMAP_THRESHOLD, 32 << 20)
    libc.mallopt(_M_TRIM_THRESHOLD, 64 << 20)


def worker_start(processes, warm=None):
    """A pool worker's start, one of `processes`: its share of the cores for its fits (workers/threads.py), its
    arrays on the heap, and warm() called (the caller's kernels compiled or loaded, so that a worker's first
    task is not charged for it)."""
    threads.share(processes)
    heap_for_arrays()
    if warm is not None:
        warm()


class Progress:
    """A one-line progress bar with an ETA on a text stream (stderr by default); into a log
    (a stream that is not a terminal) a whole line per finished task, never redrawn."""

    def __init__(self, total, label="", stream=None, width=30):
        self.total, self.label, self.width = total, label, width
        self.stream = sys.stderr if stream is None else stream
        self.done = 0
        self.t0 = time.monotonic()
        self._lock = threading.Lock()
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def note(self, text):
        """A line of its own above the bar."""
        with self._lock:
            self.stream.write(f"\r{text}\n" if self.tty else f"{text}\n")
            self.stream.flush()

    def advance(self, n=1):
        with self._lock:
            self.done += n
            elapsed = time.monotonic() - self.t0
            eta = elapsed / self.done * (self.total - self.done)
            filled = int(self.width * self.done / self.total)
            bar = "#" * filled + "." * (self.width - filled)
            start, end = ("\r", "\n" if self.done == self.total else "") if self.tty else ("", "\n")
            self.stream.write(f"{start}{self.label} [{bar}] {self.done}/{self.total} "
                              f"{elapsed:5.1f} s, ETA {eta:5.1f} s{end}")
            self.stream.flush()


def run_all(fn, jobs, executor=None, workers=None, progress=None, label="", names=None, done=None, warm=None):
    """[fn(job) for job in jobs], in parallel.

    executor: an Executor to submit to (left open); by default a process pool of
    `workers` processes (each calling warm() once as it starts) is made for the call: by default the cores this
    process may use, its share where processes share them (workers/threads.py).
    workers=1 without an executor runs in this process. progress: a stream for the
    progress bar, True for stderr, None for none. names: each job's name in messages
    (default: its number). done(i, result): called in this process as each job's result
    comes in, in the jobs' order (to keep it before the rest are done).
    """
    jobs = list(jobs)
    names = [f"{label or 'job'} {i + 1}" for i in range(len(jobs))] if names is None else list(names)
    bar = None
    if progress and jobs:
        bar = Progress(len(jobs), label, None if progress is True else progress)
    try:
        return _run(fn, jobs, names, executor, workers or threads.cores(), bar, done or (lambda i, r: None), warm)
    except BaseException:
        if bar and bar.done < bar.total:
            bar.stream.write("\n")  # an error message after us starts on its own line
        raise


def _once_more(name, result, again, bar):
    """result(), or if it raises, again() once (with a line naming the job); TaskFailed
    naming the job if that fails too."""
    try:
        return result()
    except BrokenProcessPool:  # the pool is gone: nothing to run it again on
        raise
    except Exception as e:  # noqa: BLE001 - once more, then named
        text = f"{name} failed ({type(e).__name__}: {e}): run again"
        if bar:
            bar.note(text)
        else:
            print(text, file=sys.stderr, flush=True)
    try:
        return again()
    except Exception as e:
        raise TaskFailed(f"{name} failed twice: {e}") from e


def _run(fn, jobs, names, executor, workers, bar, done, warm):
    if executor is None and (workers == 1 or len(jobs) == 1):
        out = []
        for job, name in zip(jobs, names):
            out.append(_once_more(name, lambda: fn(job), lambda: fn(job), bar))
            done(len(out) - 1, out[-1])
            if bar:
                bar.advance()
        return out
    n = min(workers, len(jobs))
    with process_pool(n, warm) if executor is None else contextlib.nullcontext(executor) as ex:
        futures = [ex.submit(fn, job) for job in jobs]
        out = []
        for f, job, name in zip(futures, jobs, names):
            out.append(_once_more(name, f.result, lambda: ex.submit(fn, job).result(), bar))
            done(len(out) - 1, out[-1])
            if bar:
                bar.advance()
        return out


@contextlib.contextmanager
def process_pool(n, warm=None):
    """A pool of n worker processes (worker_start, each calling warm). Left by a stop (Ctrl-C or SIGTERM,
    rig/operator_stop.py), it ends its workers rather than wait for them: a SIGTERM reaches
    this process alone, and its workers would run their jobs to the end (minutes of
    `dyno prove`)."""
    before = set(multiprocessing.active_children())
    ex = ProcessPoolExecutor(max_workers=n, initializer=worker_start, initargs=(n, warm))
    try:
        yield ex
    except KeyboardInterrupt:
        # killed before any shutdown: a shutdown(wait=False) first resets the executor while
        # its manager thread still runs, which a worker's death then hangs (CPython gh-132969,
        # unfixed in 3.11); killed, the pool is broken and the shutdown below ends at once
        for p in set(multiprocessing.active_children()) - before:
            p.kill()  # a SIGTERM would run the handler a forked worker inherited, mid-job
        raise
    finally:
        _shut(ex)


def _shut(ex):
    """ex shut down, its waiting futures cancelled. A stop that came while its first submit
    started the manager thread (the thread made, not yet run: the KeyboardInterrupt is raised
    just after the thread's creation) leaves a thread that join() refuses ("cannot join
    thread before it is started", a traceback after `prove: stopped`): it is given a moment
    to run, then left unjoined, its workers gone."""
    for _ in range(50):
        try:
            ex.shutdown(cancel_futures=True)
            return
        except RuntimeError:
            time.sleep(0.02)
    ex.shutdown(wait=False, cancel_futures=True)
