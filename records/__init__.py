"""A run as data and its files: the events and channels of a recording and the helpers every
analysis of one shares (events.py, data.py, strokes.py, steady.py, segmentation.py, source_filter.py); the MCAP
recorder and reader (recorder.py, reader.py, mcap_batch.py); the import of other dynos'
files (importing.py, csv_import.py, table.py, tdms.py, column_guess.py, column_units.py,
spec_table.py) and the safe file handling all of them share (files.py). It imports only
rig (its errors and quantities); the physics (models) reads records, never the reverse.

Not `recordings/`: that is where a user's runs go (`make run`, `dyno runs index`'s default)."""
import os
import sys

# One BLAS thread, as every Dask worker has: a least-squares fit sums in an order that
# depends on the thread count, so a diagnosis on one machine and on a cluster would differ
# in their last digits; and the fits' matrices are tall and narrow (samples by a few dozen
# parameters), where threads cost more than they give (a diagnosis took 36 s on one
# thread, 99 s on two cores; a sine's periodic fit at import, strokes.fit, 1 s against 18 s
# beside another process). Before numpy loads (the dyno command, a worker) by the
# environment; after (a test, a user's script), on the threads it has started.
if "numpy" not in sys.modules:
    for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")
else:
    import scipy.linalg  # noqa: F401 - its own BLAS: loaded now, so that it is limited too
    from threadpoolctl import threadpool_limits
    threadpool_limits(limits=1, user_api="blas")
