"""models/threads.py: independent fits on the cores give what one after the other gives."""
import threading

import numpy as np

from models import threads


def test_each_keeps_the_items_order_and_runs_nested_calls_in_place(monkeypatch):
    monkeypatch.delenv(threads.ENV, raising=False)  # the suite's workers have one thread each
    def slow_sum(k):
        names.add(threading.current_thread().name)
        return float(np.sum(np.sin(np.arange(200_000) * (k + 1))))

    names = set()
    items = [(k,) for k in range(6)]
    assert threads.each(slow_sum, items) == [slow_sum(*x) for x in items]
    if threads.cores() > 1:  # the work went to the pool's threads
        assert any(n.startswith(threads.PREFIX) for n in names)
    # a call from one of the pool's own threads runs there: waiting on the pool would hang
    nested = threads.each(lambda k: threads.each(slow_sum, [(k,), (k + 1,)]), [(0,), (1,)])
    assert nested == [[slow_sum(0), slow_sum(1)], [slow_sum(1), slow_sum(2)]]


def test_an_error_in_one_item_reaches_the_caller():
    def fail_on_two(k):
        if k == 2:
            raise ValueError("two")
        return k
    try:
        threads.each(fail_on_two, [(k,) for k in range(4)])
    except ValueError as e:
        assert str(e) == "two"
    else:
        raise AssertionError("the error was lost")


def test_processes_sharing_the_cores_each_fit_on_their_share(monkeypatch):
    monkeypatch.delenv(threads.ENV, raising=False)
    n = threads.cores()
    threads.share(2)  # one of two processes: half the cores, at least one
    assert threads.cores() == max(1, n // 2)
    monkeypatch.setenv(threads.ENV, "64")  # never more than the process may run on
    assert threads.cores() == n
