"""`dyno identify|diagnose --batch FILE... [--summary S.csv] [--cluster SPEC | --jobs N]`: a
lab's archive, one task per recording, on a local process pool or Dask
(protocols/cluster.py). Each task gets the recording's bytes (the workers share no disk)
and sends back a JSON document, written beside the recording (FILE.model.json,
FILE.diagnosis.json); one summary table has a row per recording. A recording that
cannot be analysed fails its own row, with its message, and the rest go on (exit 1)."""
from __future__ import annotations

import contextlib
import csv
import json
import sys
import tempfile
from pathlib import Path

from workers.pool import run_all

from protocols import cluster
from records.files import input_file, output_file, written


@contextlib.contextmanager
def unpacked(name, data):
    """The recording's bytes as a file in a temporary folder of this worker's."""
    with tempfile.TemporaryDirectory(prefix="dyno-batch-") as folder:
        path = Path(folder) / Path(name).name
        path.write_bytes(data)
        yield path


def run(args, task, extra, suffix, row, label, kept=lambda doc: doc):
    """task((name, bytes, *extra)) -> (name, document or None, error or None); row(name,
    document, error) -> {column: value}; kept(document) is written to FILE + suffix."""
    files = [input_file(f, "--batch:") for f in args.batch]
    overwrite = getattr(args, "overwrite", False)
    beside = {f: f.with_suffix(suffix) for f in files}
    for out in beside.values():  # every output is checked before any work
        output_file(out, files, overwrite, "--batch:")
    summary = output_file(args.summary, [*files, *beside.values()], overwrite, "--summary")
    tasks = [(str(f), f.read_bytes(), *extra) for f in files]
    rows = {}

    def done(i, result):  # each result written as it comes in: a stop keeps what is done
        name, doc, error = result
        if doc is not None:
            with written(beside[Path(name)]) as tmp:
                tmp.write_text(json.dumps(kept(doc), indent=1))
        rows[i] = (doc is None, row(name, doc, error))
    with cluster.pool(args.cluster, args.jobs) as (pool, workers):
        print(f"{label}: {len(tasks)} recordings on {workers} workers", file=sys.stderr, flush=True)
        try:
            run_all(task, tasks, pool, progress=True, label=label, names=[str(f) for f in files], done=done)
        except KeyboardInterrupt:  # an operator's stop: the summary says which were not analysed
            _summary(summary, [rows[i][1] if i in rows else row(str(f), None, "stopped before it was analysed")
                               for i, f in enumerate(files)])
            print(f"{label}: stopped; {len(rows)} of {len(tasks)} analysed and written beside their recordings; "
                  f"{summary} marks the rest", file=sys.stderr, flush=True)
            raise
    for failed, r in (rows[i] for i in range(len(files))):  # after the progress bar, not through it
        print(f"{r['recording']}: " + (f"FAILED: {r['error']}" if failed else "ok"), file=sys.stderr, flush=True)
    _summary(summary, [rows[i][1] for i in range(len(files))])
    print(summary)
    return 1 if any(rows[i][0] for i in rows) else 0


def _summary(path, rows):
    columns = list(dict.fromkeys(k for r in rows for k in r))  # every row's columns, in first-seen order
    with written(path, "--summary") as tmp, open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, columns)
        w.writeheader()
        w.writerows(rows)
