"""The test protocols, one short file each (thesis chapter 2), and hardware-in-the-loop."""
from protocols.library import hil, low_speed, sine_matrix, standard, static, step, temperature_sweep

PROTOCOLS = {m.NAME: m for m in (static, low_speed, sine_matrix, temperature_sweep, step, standard, hil)}
