"""What shows the diagnosis and the product work, beside the simulator: `dyno prove`'s
matrix of runs on the virtual plant with effects hidden in it (on_plant.py), effects hidden
in copies of real recordings (on_files.py), the kept results either reuses (keep.py), and
the benchmarks `dyno bench` runs (bench/). It stands above protocols (it runs plans on
cells) and below the commands that call it."""
