"""Whole segments of a run handed to a worker process without the control loop waiting:
what the live identification and the live diagnosis share. The runner's observer calls
append arrays; each segment's end moves the segment into the worker's short queue without
blocking (a backlog holds what the queue cannot take yet, so the worker may fall behind but
loses nothing), and what the worker sent back is handed to `show` on the same calls.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import queue

import numpy as np

from records.events import SegmentEnd
from rig.pacing import normal_priority

NICE = 19  # the worker yields the cores to the control loop, the recorder and (on a bench) the simulator


class SegmentFeed:
    def __init__(self, target, args, show, real_time=True):
        """target(inbox, outbox, ending, *args) runs in a spawned process (no fork of a
        process holding buses and threads), at the lowest priority when the run is in real
        time (a simulation faster than real time has no deadline to protect); show((kind,
        body)) gets what it sends back."""
        ctx = mp.get_context("spawn")
        self.inbox, self.outbox = ctx.Queue(maxsize=4), ctx.Queue()
        self.ending = ctx.Event()  # the run is over: the worker finishes what it has
        self.proc = ctx.Process(target=niced, args=(NICE if real_time else 0, target, self.inbox, self.outbox,
                                                    self.ending, *args), daemon=True)
        self.proc.start()
        self.show = show
        self.buf, self.events, self.backlog = {}, [], []

    def samples(self, drained):
        for name, (t, v) in drained.items():
            if len(t):
                self.buf.setdefault(name, []).append((np.array(t), np.array(v)))

    def event(self, e):
        self.events.append(e)
        if isinstance(e, SegmentEnd):
            self.cut()
        self.pump()

    def cut(self):
        """What was buffered, as one segment's ("data", channels, events) for the worker."""
        chunk = {n: (np.concatenate([a for a, _ in parts]), np.concatenate([b for _, b in parts]))
                 for n, parts in self.buf.items()}
        self.backlog.append(("data", chunk, self.events))
        self.buf, self.events = {}, []

    def pump(self):
        while self.backlog:
            try:
                self.inbox.put_nowait(self.backlog[0])
            except queue.Full:
                break
            self.backlog.pop(0)
        while True:
            try:
                msg = self.outbox.get_nowait()
            except queue.Empty:
                return
            self.show(msg)

    def cancel(self):
        """Stop the worker now (what it has not taken from the queue is dropped: without
        that, this process would wait at its exit to hand it over)."""
        self.inbox.cancel_join_thread()
        self.proc.terminate()
        self.proc.join(timeout=10)

    def stop(self, timeout=10.0):
        """Wait for the worker to end, then make sure it has."""
        self.proc.join(timeout=timeout)
        if self.proc.is_alive():
            self.proc.terminate()


def niced(nice, target, *args):
    """target(*args) at a lower scheduling priority: an analysis may fall behind, the loop
    may not (started by a thread under SCHED_FIFO, it leaves that first)."""
    with normal_priority():
        os.nice(nice)
        target(*args)


def merged(items):
    """One (chunk, events) of several queued ("data", chunk, events) in order."""
    names = {n for _, chunk, _ in items for n in chunk}
    chunk = {n: tuple(np.concatenate([c[n][j] for _, c, _ in items if n in c]) for j in (0, 1)) for n in names}
    return chunk, [e for *_, evs in items for e in evs]
