"""The `dyno` application: the parser table (cli.py) and one module per command."""
import os

# before numpy loads: the diagnosis's matrices are tall and narrow (samples by a dozen
# parameters), where OpenBLAS's threads cost more than they give (a diagnosis took 2.5x as
# long beside a second process), and prove and the batches run a process per core already
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
