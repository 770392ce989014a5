"""Magnetorheological (MR) dampers: Spencer's phenomenological model (spencer.py) and its
identification from a recording with the coil's drive in it (identify.py). The thesis
(Warner 1996) treats hydraulic dampers only; this room follows Spencer, Dyke, Sain and
Carlson, "Phenomenological model for magnetorheological dampers", J. Eng. Mech. 123(3),
1997 (docs/mr-damper.md)."""
