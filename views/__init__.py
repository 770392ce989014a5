"""The reading room: finished recordings read for people. Reports and their figures, the
browser view (`dyno serve`), the run index (`dyno runs`: one SQLite file beside the
recordings), exported tables and the model's documents. It reads what a run wrote and
imports nothing of the machinery that runs one (protocols/: plans, runner, cell)."""
