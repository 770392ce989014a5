"""`dyno bench cluster`: what Dask distributed gives over one worker, for the two kinds of
fan-out work: prove (few long tasks: a recording through the wires and its diagnosis) and
a quarter-car sweep, one harmonic point a task (many short tasks) and 70 points a task
(about 2 s each, the size the overhead goal is set for).

Each workload runs once on one worker in this process (serial) and once on a
LocalCluster of `workers` processes; the cluster's time is counted from the submission of
the first task to the last result, its start-up (and the workers' compilation, which
warm() does as they join) reported apart. overhead_per_task_s = (cluster_s * workers -
serial_s) / tasks: what scheduling, transfer and an idle worker at the end cost a task."""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from workers.pool import run_all
from protocols import cluster


def _prove_tasks(n):
    """n prove runs: the null and an effect hidden at some times its concealed value
    (sim_backend/plain.toml [bench.cluster]), seeds 0..."""
    from sim_backend.options import benchmark, plain_cell
    concealed, which = plain_cell()[2]["concealed"], benchmark("cluster")
    e = which["effect"]
    effects = [(None, None), (e, {e: which["times"] * concealed[e]})]
    from proof.on_plant import ProveTask
    return [ProveTask(e, None, 10.0, v, seed, 1.0, 1000.0) for seed in range(n // 2 + 1) for e, v in effects][:n]


def _sweep_tasks(n):
    from models.damper import load
    from models.quarter_car import load as load_car
    from models.quarter_car.sweeps import Harmonic, T_BASE
    car, d = load_car("simulator"), load("koni")
    return [Harmonic(car, d, 0.0127, float(f), T_BASE, True) for f in np.linspace(1.25, 20.0, n)]


def _points(jobs):
    """A batch of harmonic points as one task."""
    from models.quarter_car.sweeps import harmonic_point
    return [harmonic_point(j) for j in jobs]


def _batched_sweep_tasks(n, per_task):
    """n tasks of per_task harmonic points each (about 30 ms a point)."""
    points = _sweep_tasks(n * per_task)
    return [points[i::n] for i in range(n)]  # each task a spread of frequencies, so tasks take alike


def _same(a, b):
    """Results equal, value for value (arrays included)."""
    if dataclasses.is_dataclass(a):
        return type(a) is type(b) and _same(vars(a), vars(b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return np.array_equal(a, b, equal_nan=True)
    return a == b or (a != a and b != b)


def measure(name, fn, tasks, workers):
    t0 = time.perf_counter()
    serial = run_all(fn, tasks, workers=1, progress=True, label=f"{name} serial")
    serial_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    with cluster.executor(f"local:{workers}") as (ex, n):
        startup_s = time.perf_counter() - t0
        t1 = time.perf_counter()
        remote = run_all(fn, tasks, ex, progress=True, label=f"{name} on {n} workers")
        cluster_s = time.perf_counter() - t1
    return {"name": name, "tasks": len(tasks), "workers": n, "serial_s": serial_s, "cluster_s": cluster_s,
            "startup_s": startup_s, "speedup": serial_s / cluster_s, "efficiency": serial_s / (cluster_s * n),
            "task_s": serial_s / len(tasks), "overhead_per_task_s": (cluster_s * n - serial_s) / len(tasks),
            "identical": _same(serial, remote)}


def bench(workers=2, prove_tasks=6, sweep_tasks=60):
    from models.quarter_car.sweeps import harmonic_point
    from proof.on_plant import run_task
    rows = [measure("prove", run_task, _prove_tasks(prove_tasks), workers),
            measure("sweep", harmonic_point, _sweep_tasks(sweep_tasks), workers),
            measure("sweep, 70 points a task", _points, _batched_sweep_tasks(8, 70), workers)]
    return {"rows": rows, "goals": {"speedup": 1.8, "overhead_share_for_2s_tasks": 0.05}}
