"""`dyno sim-rig` and `dyno rig check`."""
from __future__ import annotations

import signal
import sys
import threading
import time

from rig import config as rig_config
from rig.errors import RigError
from rig.rig import Rig

CHECK_S = 0.5  # how long rig check listens


def open_rig(args):
    """(rig, virtual rig or None, pacer step): the embedded virtual rig unless --rig."""
    if args.rig is None:
        from sim_backend.virtual_rig import VirtualRig
        vr = VirtualRig(rig_config.load("virtual"), damper=args.damper)
        cfg = vr.start()
        rig = Rig(cfg, clock=vr.clock)
        return rig, vr
    cfg = rig_config.load(args.rig)
    return Rig(cfg), None


def rig_check(args):
    rig, vr = open_rig(args)
    try:
        rig.open()
        t_end = None
        while True:
            if vr is not None:
                vr.step(1e-3)
            else:
                time.sleep(1e-3)
            now = rig.poll()
            t_end = now + CHECK_S if t_end is None else t_end
            if now >= t_end:
                break
        readings = rig.read()
        cfg = rig.config
        where = "embedded virtual rig" if vr is not None else cfg.path
        print(f"rig {cfg.name!r} ({where})")
        print(f"{'channel':12s} {'device':12s} {'value':>14s} {'unit':5s} {'age':>8s}  status")
        missing = []
        for name, ch in cfg.channels.items():
            r = readings.get(name)
            if r is None:
                missing.append(f"{name} ({ch.device})")
                print(f"{name:12s} {ch.device:12s} {'-':>14s} {ch.unit:5s} {'-':>8s}  NO DATA")
                continue
            status = "ok" if r.fault is None else f"FAULT: {r.fault}"
            if r.fault:
                missing.append(f"{name} ({ch.device}: {r.fault})")
            print(f"{name:12s} {ch.device:12s} {r.value:14.6g} {ch.unit:5s} {1e3 * (now - r.t):6.0f} ms  {status}")
        state, alarms = rig.actuator()
        print(f"actuator: {state}, {'alarms: ' + ', '.join(alarms) if alarms else 'no alarms'}")
        if state == "unknown":
            missing.append(f"actuator status ({cfg.actuator})")
        if missing:
            print(f"dyno: error: rig check: no data or faulted: {', '.join(missing)}", file=sys.stderr)
            return 1
        print(f"all {len(cfg.channels)} channels report")
        return 0
    finally:
        rig.close()
        if vr is not None:
            vr.close()


def parse_faults(specs):
    """['open_thermocouple@2.5', 'can_bus_off'] -> [(2.5, 'open_thermocouple'), (0.0, 'can_bus_off')]."""
    from sim_backend.virtual_rig import FAULTS
    out = []
    for spec in specs or ():
        name, _, at = spec.partition("@")
        if name not in FAULTS and name != "process_death":
            raise RigError(f"--fault {spec}: unknown fault (known: {', '.join(FAULTS)}, process_death)")
        try:
            t = float(at) if at else 0.0
        except ValueError:
            raise RigError(f"--fault {spec}: the time after @ must be seconds") from None
        out.append((t, name))
    return out


def sim_rig(args):
    from sim_backend.virtual_rig import VirtualRig
    faults = parse_faults(args.fault)
    cfg = rig_config.load(args.config)
    vr = VirtualRig(cfg, damper=args.damper)
    try:
        served = vr.start()
    except OSError as e:
        raise RigError(f"sim-rig: cannot serve {cfg.path} ({e.strerror or e})") from None
    for name, d in served.devices.items():
        addr = {"can": lambda p: f"{p['interface']} {p['channel']} {p.get('host', '')}:{p.get('port', '')}".rstrip(":"), "serial": lambda p: p["port"],
                "modbus": lambda p: f"{p['host']}:{p['port']} id {p['device_id']}"}[d.transport](d.params)
        print(f"sim-rig: {name:12s} {d.transport:7s} {addr}")
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
