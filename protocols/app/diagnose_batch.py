"""`dyno diagnose --batch FILE... [--summary S.csv] [--cluster SPEC]`: a lab's archive
diagnosed one task per recording, on a local process pool or Dask (protocols/cluster.py).
Each task gets the recording's bytes (the workers share no disk) and sends back the
diagnosis as JSON, written beside the recording as FILE.diagnosis.json; one summary table
has a row per recording. A recording that cannot be diagnosed fails its own row, with its
message, and the rest go on."""
from __future__ import annotations

import csv
import json
import sys
import tempfile
from pathlib import Path

from rig.errors import RigError

from protocols import cluster

SUMMARY = ("recording", "error", "baseline_nrmse_heldout", "final_nrmse_heldout", "final_rmse_heldout_N",
           "final_r2_heldout", "accepted", "may_compensate")


def _one(task):
    """(name, JSON result or None, error message or None) of one recording's bytes."""
    name, data, baseline, holdout = task
    from models.damper import DamperError, from_dict
    from models.diagnose import diagnose
    from models.diagnose.data import DiagnoseError
    from protocols.app.diagnose import to_json
    from protocols.io.reader import load_recording
    with tempfile.TemporaryDirectory(prefix="dyno-batch-") as folder:
        path = Path(folder) / Path(name).name
        path.write_bytes(data)
        try:
            ch, events, _ = load_recording(path)
            base = None if baseline is None else (baseline[0], from_dict(baseline[1]))
            res = diagnose(ch, events, progress=lambda s: None, baseline=base, holdout=holdout)
        except (RigError, DiagnoseError, DamperError) as e:
            return name, None, str(e).replace(str(path), name)
    return name, to_json(res), None


def _row(name, doc, error):
    if doc is None:
        return {"recording": name, "error": error}
    held = (lambda part, k: doc[part][k])
    return {"recording": name, "error": "", "baseline_nrmse_heldout": held("baseline", "nrmse_heldout"),
            "final_nrmse_heldout": held("final", "nrmse_heldout"), "final_rmse_heldout_N": held("final", "rmse_heldout"),
            "final_r2_heldout": held("final", "r2_heldout"), "accepted": ";".join(doc["accepted"]),
            "may_compensate": ";".join(f"{k}~{'/'.join(v)}" for k, v in doc["may_compensate"].items())}


def run(args, baseline):
    """baseline: None (the minimal model) or (name, damper dict)."""
    files = [Path(f) for f in args.batch]
    missing = [f for f in files if not f.is_file()]
    if missing:
        raise RigError(f"--batch: {missing[0]}: no such file")
    summary = Path(args.summary or "diagnosis-summary.csv")
    tasks = [(str(f), f.read_bytes(), baseline, args.holdout) for f in files]
    rows, failed = [], 0
    with cluster.pool(args.cluster, args.jobs) as (pool, workers):
        print(f"diagnosing {len(tasks)} recordings on {workers} workers", file=sys.stderr, flush=True)
        for i, (name, doc, error) in enumerate(pool.map(_one, tasks), 1):
            if doc is not None:
                Path(name).with_suffix(".diagnosis.json").write_text(json.dumps(doc, indent=1))
            failed += doc is None
            rows.append(_row(name, doc, error))
            print(f"[{i}/{len(tasks)}] {name}: " + (f"FAILED: {error}" if doc is None else
                                                   f"accepted {', '.join(doc['accepted']) or 'nothing'}"),
                  file=sys.stderr, flush=True)
    with open(summary, "w", newline="") as f:
        w = csv.DictWriter(f, SUMMARY)
        w.writeheader()
        w.writerows(rows)
    print(summary)
    return 1 if failed else 0
