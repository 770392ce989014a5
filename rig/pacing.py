"""Who owns time in the control loop: SimulatedPacer steps the virtual rig by one period
per tick (as fast as the CPU allows); RealTimePacer sleeps to wall-clock deadlines and
reports each tick's lateness. A pacer only paces: the time of a tick is the rig's clock."""
from __future__ import annotations

import ctypes
import os
import platform
import sys
import time
from contextlib import contextmanager


# SCHED_FIFO priority of the threads a wall-clock cell starts (devices' readers, emulators,
# the recorder): above every normal program, below the loop's own (rig.realtime_priority)
THREADS_PRIORITY = 1
# ...and the devices' pollers one above those: a poll is a millisecond's work on a deadline,
# while a CPU-bound thread at the same SCHED_FIFO priority is never made to yield to it (equal
# FIFO threads do not share a core by time; CI on a 3x slower host: a 10 Hz thermocouple
# module went 1.15 s without a reading, its poller at 1 beside the observers' thread, while
# the loop kept time).
DEVICE_PRIORITY = 2

# share of a wall-clock tick an embedded virtual rig waits for its frames to reach the driver
SETTLE_SHARE = 0.25


# The loop's slice under the normal policy where SCHED_FIFO is not granted: Linux's EEVDF
# scheduler (6.12 on) lets a thread ask for a shorter slice, which gives it an earlier
# virtual deadline, so on waking it preempts a CPU-bound program instead of waiting out that
# program's slice (1.4 ms on a 2-core machine here). No privilege is needed: a shorter slice
# gives no more CPU time, only sooner (docs/wiring.md has the measurement).
LOOP_SLICE_S = 1e-4  # the kernel's shortest

# sched_setattr/sched_getattr by architecture (the C library wraps neither)
_SCHED_ATTR_CALLS = {"x86_64": (314, 315), "aarch64": (274, 275)}


class _SchedAttr(ctypes.Structure):
    _fields_ = [("size", ctypes.c_uint32), ("policy", ctypes.c_uint32), ("flags", ctypes.c_uint64),
                ("nice", ctypes.c_int32), ("priority", ctypes.c_uint32), ("runtime", ctypes.c_uint64),
                ("deadline", ctypes.c_uint64), ("period", ctypes.c_uint64),
                ("util_min", ctypes.c_uint32), ("util_max", ctypes.c_uint32)]


def _sched_attr(new_runtime_ns=None):
    """This thread's sched_attr; with new_runtime_ns, set its slice first. None where the
    kernel or the architecture has no such call."""
    calls = _SCHED_ATTR_CALLS.get(platform.machine())
    if calls is None or not sys.platform.startswith("linux"):
        return None
    libc = ctypes.CDLL(None, use_errno=True)
    attr = _SchedAttr()
    if libc.syscall(calls[1], 0, ctypes.byref(attr), ctypes.sizeof(attr), 0) != 0:
        return None
    if new_runtime_ns is not None:
        if attr.policy != os.SCHED_OTHER:
            return None
        old = attr.runtime
        attr.size, attr.runtime = ctypes.sizeof(attr), int(new_runtime_ns)
        if libc.syscall(calls[0], 0, ctypes.byref(attr), 0) != 0:
            return None
        attr.runtime = old
    return attr


def short_slice(slice_s=LOOP_SLICE_S):
    """Ask for a short EEVDF slice for this thread (normal policy); returns what to give
    restore_slice, or None where the kernel takes no such request."""
    return _sched_attr(slice_s * 1e9)


def restore_slice(attr):
    calls = _SCHED_ATTR_CALLS[platform.machine()]
    ctypes.CDLL(None, use_errno=True).syscall(calls[0], 0, ctypes.byref(attr), 0)


def _policy():
    """This thread's scheduling policy and its parameters, as restore_priority takes them."""
    return os.sched_getscheduler(0), os.sched_getparam(0)


def realtime_priority(priority):
    """Switch this thread to SCHED_FIFO; returns the policy to restore, or None if not
    asked for or not allowed (Linux as root, or within an rtprio limit). Threads it
    starts from then on inherit the policy."""
    if not priority or not hasattr(os, "SCHED_FIFO"):
        return None
    old = _policy()
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(int(priority)))
    except OSError:
        return None
    return old


def above_normal(config):
    """A wall-clock cell's threads (devices' readers, emulators, the recorder): this thread
    and those it starts from now on at THREADS_PRIORITY if the rig config asks for
    real-time priority; the policy to restore, or None."""
    return realtime_priority(THREADS_PRIORITY if config.realtime_priority else None)


def device_thread():
    """A device's own thread (a polled module's): above the cell's other threads
    (DEVICE_PRIORITY) if it was started under SCHED_FIFO, else on the shortest slice: a
    poll is a millisecond's work on a deadline."""
    if under_fifo():
        realtime_priority(DEVICE_PRIORITY)
    else:
        short_slice()


def restore_priority(policy):
    """Give this thread back the policy realtime_priority returned."""
    os.sched_setscheduler(0, *policy)


def under_fifo():
    """Does this thread run under SCHED_FIFO?"""
    return hasattr(os, "SCHED_FIFO") and os.sched_getscheduler(0) == os.SCHED_FIFO


@contextmanager
def normal_priority():
    """This thread, and the threads and processes it starts meanwhile, under the normal
    policy: an analysis on a wall-clock cell (between its runs, or in a worker beside one)
    keeps no other program of the computer waiting."""
    old = _policy() if under_fifo() else None
    if old is not None:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    try:
        yield
    finally:
        if old is not None:
            restore_priority(old)


class SimulatedPacer:
    """Simulated clock: each tick advances the virtual rig by one period."""
    wall_clock = False

    def __init__(self, virtual_rig, rate_hz):
        self.vr, self.dt = virtual_rig, 1.0 / rate_hz

    def wait_next(self):
        self.vr.step(self.dt)
        return 0.0


class RealTimePacer:
    """Wall clock: sleeps to each deadline (the last 0.1 ms spun for precision); returns
    the tick's lateness. With a virtual rig, steps it by the elapsed time. It only paces:
    the time of a tick is the rig's clock."""
    wall_clock = True

    def __init__(self, rate_hz, virtual_rig=None, spin_s=1e-4, fifo_priority=None):
        """fifo_priority: run the loop thread under SCHED_FIFO at this priority (1-99)
        while it runs, if the OS allows (Linux, privileged); as a dedicated cell would."""
        self.dt, self.vr, self.spin = 1.0 / rate_hz, virtual_rig, spin_s
        self.fifo_priority = fifo_priority
        self.t0 = None
        self.k = 0
        self.missed = 0  # ticks skipped after stalls

    def wait_next(self):
        if self.t0 is None:
            self.t0 = time.perf_counter()
        self.k += 1
        due = deadline = self.t0 + self.k * self.dt
        behind = time.perf_counter() - deadline
        skip = 0
        if behind > self.dt:  # a stall: skip the ticks it swallowed rather than burst them
            skip = int(behind / self.dt)
            self.k += skip
            self.missed += skip
            deadline += skip * self.dt
        while True:
            left = deadline - time.perf_counter()
            if left <= 0:
                break
            if left > self.spin:
                time.sleep(left - self.spin)
        now = time.perf_counter()
        if self.vr is not None:
            # the frames may reach the driver a tick late, as on a real cell, rather than
            # make the loop wait for the kernel's worker (rig/stream_clock.py dates them)
            self.vr.step(self.dt * (1 + skip), settle_s=SETTLE_SHARE * self.dt)
        return now - due  # lateness counts the stall
