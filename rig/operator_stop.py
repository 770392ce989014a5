"""Ctrl-C (and SIGTERM) as an operator stop that cannot be lost or hang the rig.

The handler sets OPERATOR_STOP, then raises KeyboardInterrupt unless a quiet section is
running: the control loop (an exception raised at any bytecode could leave a device's or a
bus's lock held, and the process would hang) or a file changing state with the variable
that says so. A KeyboardInterrupt raised inside a finaliser is only reported by Python,
never propagated; the flag stays set, and the loop and the run's start-up look at it
(`raise_if_stopped`), so a stop is never swallowed.
"""
from __future__ import annotations

import contextlib
import signal
import threading

OPERATOR_STOP = threading.Event()
_quiet = 0  # depth of quiet sections (main thread only: Python runs handlers there)


def on_signal(signum, frame):
    OPERATOR_STOP.set()
    if not _quiet:
        raise KeyboardInterrupt


@contextlib.contextmanager
def quiet():
    """A section where a stop only sets the flag (looked at after it); on the main thread,
    where Python runs signal handlers (a loop on another thread needs none)."""
    global _quiet
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _quiet += 1
    try:
        yield
    finally:
        _quiet -= 1


def raise_if_stopped():
    if OPERATOR_STOP.is_set():
        raise KeyboardInterrupt


@contextlib.contextmanager
def handled():
    """on_signal for SIGINT and SIGTERM for the block, on the main thread, the flag cleared
    first and when the block ends (a stop belongs to the command it stopped: left set, it
    stopped every later run in the same process at its first tick); a no-op where it is set
    already (a stop since is kept) or off the main thread (only the main thread may set
    handlers)."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is on_signal:
        yield
        return
    OPERATOR_STOP.clear()
    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        OPERATOR_STOP.clear()
