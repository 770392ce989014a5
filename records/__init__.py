"""A run as data and its files: the events and channels of a recording and the helpers every
analysis of one shares (events.py, data.py, strokes.py, steady.py, segmentation.py, source_filter.py); the MCAP
recorder and reader (recorder.py, reader.py, mcap_batch.py); the import of other dynos'
files (importing.py, csv_import.py, table.py, tdms.py, column_guess.py, column_units.py,
spec_table.py) and the safe file handling all of them share (files.py). It imports only
rig (its errors and quantities); the physics (models) reads records, never the reverse.

Not `recordings/`: that is where a user's runs go (`make run`, `dyno runs index`'s default)."""
