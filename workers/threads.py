"""Independent fits on the process's cores, as threads: the model evaluations they spend
their time in are numpy and numba kernels compiled `nogil`, which release the GIL.
Results come back in the items' order, so a caller gets what one item after the other
would have given."""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

PREFIX = "model-fit"
_pool = (None, None)  # (process id, executor): a forked child does not inherit its parent's threads
_lock = threading.Lock()


# how many threads one process's fits may use (default: the cores it may run on). Processes
# that share the machine's cores each get their share: a process pool's workers and a test
# suite's (workers/pool.py, tests/conftest.py): threads beyond the free cores would only
# contend for the GIL and the caches
ENV = "DYNO_FIT_THREADS"


def cores() -> int:
    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    share = os.environ.get(ENV, "")
    return max(1, min(n, int(share))) if share.isdigit() else n


def share(processes: int) -> None:
    """This process (and what it starts) is one of `processes` sharing the cores."""
    os.environ[ENV] = str(max(1, cores() // max(processes, 1)))


def each(fn, items) -> list:
    """[fn(*item) for item in items], on up to `cores()` threads. One after the other on a
    single core, for a single item, or when called from one of the threads itself (a fit
    that waited on the pool it runs in would wait for ever)."""
    items = list(items)
    n = cores()
    if len(items) < 2 or n < 2 or threading.current_thread().name.startswith(PREFIX):
        return [fn(*x) for x in items]
    global _pool
    with _lock:
        if _pool[0] != os.getpid():
            _pool = (os.getpid(), ThreadPoolExecutor(n, thread_name_prefix=PREFIX))
    return list(_pool[1].map(lambda x: fn(*x), items))


_JOB = None  # (fn, items) of the forked map running: what its children inherit


def _forked_call(i):
    fn, items = _JOB
    return fn(*items[i])


def forked(fn, items, processes) -> list:
    """[fn(*item) for item in items], in up to `processes` forked children. For fits whose
    Python holds the GIL, so that threads cannot share them out: the children inherit fn,
    the items and everything compiled, and send back only the results (which must pickle).
    Results in the items' order; in this process when one process or item is asked for."""
    global _JOB
    items = list(items)
    n = min(processes, len(items))
    if n < 2:
        return [fn(*x) for x in items]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    _JOB = (fn, items)
    try:
        # each child one core's share: its own fits run one after the other. (An executor, not
        # multiprocessing's Pool: a child that dies raises BrokenProcessPool, where Pool waits for ever)
        with ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("fork"), initializer=share,
                                 initargs=(n,)) as pool:
            return list(pool.map(_forked_call, range(len(items))))
    finally:
        _JOB = None
