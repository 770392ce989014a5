"""The test protocols, one short file each (thesis chapter 2)."""
from . import sine_matrix, step

PROTOCOLS = {m.NAME: m for m in (sine_matrix, step)}
