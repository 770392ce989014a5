"""The test protocols, one short file each (thesis chapter 2), hardware-in-the-loop and replay."""
from protocols.library import hil, low_speed, replay, sine_matrix, standard, static, step, temperature_sweep

PROTOCOLS = {m.NAME: m for m in (static, low_speed, sine_matrix, temperature_sweep, step, standard, hil, replay)}
