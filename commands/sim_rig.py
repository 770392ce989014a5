"""`dyno sim-rig`: the virtual rig served as its own process on the wire protocols a real
cell speaks (socketcand, a pty, Modbus TCP), with faults to inject."""
from __future__ import annotations

import math
import signal
import threading

from rig.errors import UsageError

from commands.arguments import hidden_physics, number, virtual_plant


def add(sub):
    """The `dyno sim_rig` command's arguments."""
    sr = sub.add_parser("sim-rig", help="serve the virtual rig as its own process (CAN socketcand, pty, Modbus TCP)")
    sr.add_argument("--config", default="sim-rig", help="rig config to serve (default: sim-rig)")
    sr.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    sr.add_argument("--fault", action="append", metavar="NAME[@TIME]", help="inject a fault, at TIME s")
    hidden_physics(sr)
    sr.add_argument("--seconds", type=number(above=0), default=None, help="stop after this long")
    sr.set_defaults(command="sim_rig")


def parse_faults(specs):
    """['open_thermocouple@2.5', 'can_bus_off'] -> [(2.5, 'open_thermocouple'), (0.0, 'can_bus_off')]."""
    from sim_backend.virtual_rig import FAULTS
    out = []
    for spec in specs or ():
        name, _, at = spec.partition("@")
        if name not in FAULTS and name != "process_death":
            raise UsageError(f"--fault {spec}: unknown fault (known: {', '.join(FAULTS)}, process_death)")
        try:
            t = float(at) if at else 0.0
        except ValueError:
            t = math.nan
        if not (math.isfinite(t) and t >= 0):
            raise UsageError(f"--fault {spec}: the time after @ must be seconds from the start (0 or more)")
        out.append((t, name))
    return out


def run(args):
    from rig import config as rig_config
    from rig.devices import TRANSPORTS
    from rig.pacing import above_normal
    from sim_backend.virtual_rig import VirtualRig
    faults = parse_faults(args.fault)
    cfg = rig_config.load(args.config)
    p = virtual_plant(args)
    vr = VirtualRig(cfg, damper=p.damper, seed=p.seed, effects=p.effects, params=p.params)
    # the emulators' threads above every normal program, as the devices of a real cell are
    # (rig.realtime_priority); the stepping thread raises itself further
    above_normal(cfg)
    try:
        served = vr.start()
    except OSError as e:
        raise UsageError(f"sim-rig: cannot serve {cfg.path} ({e.strerror or e})") from None
    for name, d in served.devices.items():
        print(f"sim-rig: {name:12s} {d.transport:7s} {TRANSPORTS[d.transport].address(d.params)}")
    print(f"sim-rig: serving {served.name!r} with damper {vr.plant.damper.name} in real time; Ctrl-C stops",
          flush=True)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    timers = []
    if args.seconds:
        timers.append(threading.Timer(args.seconds, stop.set))
    die = [t for t, n in faults if n == "process_death"]
    if die:
        import os
        timers.append(threading.Timer(die[0], lambda: os._exit(3)))  # the whole emulator dies
    for t in timers:
        t.daemon = True  # never keep the process alive after a stop
        t.start()
    try:
        vr.run_realtime(stop, faults=[f for f in faults if f[1] != "process_death"])
    except KeyboardInterrupt:
        pass
    finally:
        vr.close()
    return 0
