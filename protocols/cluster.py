"""`--cluster local[:WORKERS] | tcp://HOST:PORT`: fan-out work on Dask distributed instead of
a local process pool. Dask is optional (`pip install 'dyno[cluster]'`); the executor it
gives is a concurrent.futures one, for workers.pool.run_all (progress over the tasks,
a failed task run once more and then named). Every worker compiles the physics kernels
once when it joins (workers.pool.warm), not inside the first task.

    with pool("local:2", jobs=2) as (ex, workers):
        results = run_all(task, jobs, ex, progress=True)  # in job order; a dead worker's task is re-run
"""
from __future__ import annotations

import contextlib
import os
import re

from workers import threads
from models.physics.simulate import warm
from workers.pool import process_pool, worker_start
from rig.errors import UsageError

INSTALL = "pip install 'dyno[cluster]' (Dask distributed)"


def parse(spec: str):
    """("local", workers or None) or ("tcp", address); RigError names a bad one."""
    m = re.fullmatch(r"local(?::(\d+))?", spec)
    if m:
        workers = int(m.group(1)) if m.group(1) else None
        if workers is not None and not 1 <= workers <= 1024:
            raise UsageError(f"--cluster {spec}: WORKERS must be 1-1024")
        return "local", workers
    if re.fullmatch(r"tcp://[^\s:/]+:\d+", spec):
        return "tcp", spec
    raise UsageError(f"--cluster {spec!r}: give local, local:WORKERS or tcp://HOST:PORT (a Dask scheduler)")


@contextlib.contextmanager
def pool(spec, jobs):
    """(Executor, workers): the Dask cluster `spec`, or without one a local process pool
    of `jobs` processes."""
    if spec:
        with executor(spec) as out:
            yield out
        return
    n = max(1, jobs)
    with process_pool(n, warm) as local:
        yield local, n


def _warm_plugin():
    """A Dask worker plugin (Dask wants the subclass): models.physics.simulate.warm() once in each
    worker as it starts, and one thread for its fits (a worker is one of a machine's
    processes, each with its one thread: workers/threads.py)."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class Warm(WorkerPlugin):
        name = "dyno-warm"

        def setup(self, worker):
            worker_start(threads.cores(), warm)  # one process per core: one fit thread each
    return Warm()


CONNECT_S = 10.0  # a scheduler's time to answer: Dask tries again until then (one may be starting)


@contextlib.contextmanager
def executor(spec: str):
    """(concurrent.futures Executor, number of workers) on the cluster `spec`; a local one
    is started for the call (processes, one thread each, everything on 127.0.0.1) and
    stopped after it."""
    kind, arg = parse(spec)
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise UsageError(f"--cluster needs Dask: {INSTALL}") from None
    cluster = None
    env = dict(os.environ)  # a LocalCluster's nannies write their workers' settings into ours (below)
    try:
        if kind == "local":
            # CRITICAL: a task's failure comes back through its future; what the workers log at
            # ERROR is shutdown noise (a heartbeat racing the scheduler's close) printed as a traceback
            cluster = LocalCluster(n_workers=arg or threads.cores(), threads_per_worker=1, processes=True,
                                   host="127.0.0.1", dashboard_address=None, silence_logs=50)
            client = Client(cluster)
        else:
            client = Client(arg, timeout=f"{CONNECT_S}s")
    except OSError as e:
        if cluster is not None:
            cluster.close()
            _restore(env)
        raise UsageError(f"--cluster {spec}: cannot connect ({e})") from None
    try:
        workers = len(client.scheduler_info()["workers"])
        client.register_plugin(_warm_plugin())  # also on workers that join later
        yield client.get_executor(pure=False), workers
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
            _restore(env)


def _restore(env):
    """os.environ as `env` again. A nanny sets its workers' environment in its own process
    before it starts one: MALLOC_TRIM_THRESHOLD_ among it, which would make every process
    this one starts afterwards fault in each large array anew (workers.pool.heap_for_arrays)."""
    for k in set(os.environ) - set(env):
        del os.environ[k]
    os.environ.update(env)
