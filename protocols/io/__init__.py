"""Recordings on disk: MCAP writing and recovery, reading, CSV import, files never lost."""
