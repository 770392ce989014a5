"""A test cell to run plans on: the rig, what paces it, its config as served and the damper
on it. One factory per kind, and `protocols.runner.run_plan(plan, cell, observers)` runs a
plan on any of them:

    with cell.embedded("koni") as c:           # the virtual rig over its wire protocols
        result = runner.run_plan(Plan(sine_matrix, params), c, [recorder])
    cell.wired(rig_config.load("cell.toml"), damper)   # a real cell (or `dyno sim-rig`)
    cell.direct(config, "koni", PlantOptions(effects=...))   # the plant without wires: many times faster
    cell.model(config, damper)                 # the damper model alone: a real cell's pre-flight

A cell outlives a run: `dyno run discover` runs several plans on one, and between them the
actuator holds where the last one left it (its command watchdog holds a lost controller).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from rig.pacing import RealTimePacer, SimulatedPacer, above_normal, restore_priority
from rig.safety import Safety

from protocols.plan import rig_info


@dataclass
class Cell:
    rig: object  # the Rig interface (rig/rig.py), open
    config: object  # the rig config as served ("auto" addresses filled in)
    damper: object | None  # the damper model the plans are made for (None: none known)
    plant: object | None = None  # what a simulated clock steps (a VirtualRig, a DirectRig); None: a real cell
    realtime: bool = False  # paced by the wall clock (always, on a real cell)
    _close: list = field(default_factory=list, repr=False)

    @property
    def paced(self):
        """Does the run keep the wall clock's time (a real cell, or --realtime)?"""
        return self.realtime or self.plant is None

    @property
    def info(self):
        """RigInfo of this cell and damper for the plans."""
        return rig_info(self.config, self.damper)

    def pacer(self):
        """A new pacer for one run (a real-time pacer keeps its deadlines from its first tick)."""
        rate = self.config.rate_hz
        if self.paced:
            return RealTimePacer(rate, virtual_rig=self.plant, fifo_priority=self.config.realtime_priority)
        return SimulatedPacer(self.plant, rate)

    def safety(self):
        return Safety(self.config)

    def close(self):
        """Close the rig, then what serves it; RigError of the first that failed, after all."""
        errors = []
        for close in self._close:
            try:
                close()
            except Exception as e:  # noqa: BLE001 - everything is closed whatever one does
                errors.append(e)
        self._close.clear()
        if errors:
            raise errors[0]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _opened(c: Cell) -> Cell:
    """The cell with its rig open; if the open fails, everything closed and its error raised."""
    try:
        c.rig.open()
    except BaseException:
        try:
            c.close()
        except Exception:  # noqa: BLE001 - the open's error is the one to report
            pass
        raise
    return c


def _above_normal(c: Cell, config):
    """The cell's threads above every normal program until it closes (rig.pacing.above_normal);
    a run's loop raises its own thread further. A busy program beside a run (an analysis on
    the cell's computer) then waits for the run, not the run for it."""
    old = above_normal(config)
    if old is not None:
        c._close.append(lambda: restore_priority(old))


def embedded(damper, config=None, realtime=False, plant=None) -> Cell:
    """The embedded virtual rig: the plant behind its emulators, read through the same wire
    protocols a real cell speaks. damper: a preset name, JSON path or Damper; plant: its
    PlantOptions (sim_backend/options.py; its damper field is not read here)."""
    from models.damper import load as load_damper
    from rig import config as rig_config
    from rig.rig import Rig
    from sim_backend.virtual_rig import VirtualRig
    d = load_damper(damper)
    from sim_backend.options import PlantOptions
    p = plant or PlantOptions()
    config = config or rig_config.load("virtual")
    vr = VirtualRig(config, damper=d, seed=p.seed, T0=p.T0, effects=p.effects, params=p.params)
    c = Cell(None, None, d, vr, realtime, [vr.close])
    if realtime:
        _above_normal(c, config)  # before the emulators start their threads
    c.config = vr.start()
    c.rig = Rig(c.config, clock=vr.clock)
    c._close.insert(0, c.rig.close)
    return _opened(c)


def wired(config, damper=None) -> Cell:
    """A cell on its wires (a real one, or `dyno sim-rig` serving the virtual rig), in real time."""
    from rig.rig import Rig
    rig = Rig(config)  # its devices' threads start as it opens
    c = Cell(rig, config, damper, None, True, [rig.close])
    _above_normal(c, config)
    return _opened(c)


def direct(config, damper, plant=None) -> Cell:
    """The virtual plant without wires (rig/direct_rig.py), on its simulated clock: for the
    calibration, the rehearsal and work that needs the runner's stepping, not the wires."""
    from models.damper import load as load_damper
    from rig.direct_rig import DirectRig
    from sim_backend.options import PlantOptions
    from sim_backend.plant import Plant
    d = load_damper(damper)
    p = plant or PlantOptions()
    rig = DirectRig(config, Plant(d, T0=p.T0, h=min(5e-4, 1.0 / config.rate_hz), seed=p.seed, params=p.params,
                                  effects=p.effects))
    return _opened(Cell(rig, config, d, rig, False, []))


def model(config, damper) -> Cell:
    """The damper model alone on a perfect actuator, on its simulated clock: a real cell's
    pre-flight (protocols/rehearsal.py), which knows the cell's damper and limits but none
    of the virtual plant's parameters."""
    import dataclasses

    from models.damper import load as load_damper
    from rig.direct_rig import DirectRig
    d = load_damper(damper)
    plant = _DamperModel(d, 1.0 / config.rate_hz, rig_info(config, d).T_ambient)
    # the cell's channels the model reads: no other is watched (it would never report)
    config = dataclasses.replace(config, channels={n: ch for n, ch in config.channels.items()
                                                   if n in plant.readings()})
    rig = DirectRig(config, plant)
    return _opened(Cell(rig, config, d, rig, False, []))


class _DamperModel:
    """The damper model (models/physics/simulate.Stepper) at the cell's ambient T [K],
    driven exactly where it is commanded (the setpoint ramped over one command, as a servo
    controller does), read without noise: what a plan does to the damper, not to a cell."""

    def __init__(self, damper, h, T):
        from models.physics.simulate import Stepper
        from rig.codecs.actuator import MODES, STATES
        self.T = T
        self.x = self.setpoint = damper.mid_stroke  # m
        self.v = self.F = 0.0
        self.P = ()  # Pa: P1, P2, P_gas (none before the first step)
        self.h, self.follow = h, MODES["follow"]
        self.stepper = Stepper(damper, self.T, self.x, h)
        state = {v: k for k, v in STATES.items()}
        self.state_of = {MODES["off"]: state["off"], MODES["hold"]: state["holding"], self.follow: state["following"]}
        self.mode, self.alarm = MODES["hold"], 0
        self.state = self.state_of[self.mode]

    def command(self, mode, x):
        self.mode = int(mode)
        self.state = self.state_of[self.mode]
        if mode == self.follow:
            self.setpoint = float(x)

    def advance(self, seconds):
        n = max(1, int(round(seconds / self.h)))
        x0 = self.x
        target = self.setpoint if self.mode == self.follow else x0
        for k in range(1, n + 1):  # pressures [Pa] and the other forces are the model's own
            x = x0 + (target - x0) * k / n
            self.v, self.x = (x - self.x) / self.h, x
            self.F, _, _, _, *self.P = self.stepper.step(self.x, self.v)

    def readings(self):
        P1, P2, P_gas = self.P or (0.0, 0.0, 0.0)
        return {"force": self.F, "x": self.x, "v": self.v, "x_internal": self.x, "T_body": self.T,
                "T_reservoir": self.T, "P_gas": P_gas, "P1": P1, "P2": P2}
