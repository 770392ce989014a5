"""Independent work spread over the cores: fits as threads (threads.py) and jobs over a
process pool or a Dask cluster's executor (pool.py). It knows nothing of dampers: the
physics library fans out through it, so it sits below every other room."""
