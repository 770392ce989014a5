"""`dyno rig check [--rig CELL.toml]`: connect to every device and print each channel,
flagging implausible readings and readings beyond the limits."""
from __future__ import annotations

import sys
import time

from commands.arguments import units


CHECK_S = 0.5  # how long rig check listens


def add(sub):
    """The `dyno rig check` command's arguments."""
    rc = sub.add_parser("check", help="connect to every device and print each channel")
    rc.add_argument("--rig", default=None, help="rig config (default: the embedded virtual rig)")
    rc.add_argument("--damper", default="koni", help="damper in the embedded virtual rig (default koni)")
    units(rc)
    rc.set_defaults(command="rig_check")


def open_rig(args):
    """(rig, virtual rig or None, pacer step): the embedded virtual rig unless --rig."""
    from rig import config as rig_config
    from rig.rig import Rig
    if args.rig is None:
        from sim_backend.virtual_rig import VirtualRig
        vr = VirtualRig(rig_config.load("virtual"), damper=args.damper)
        cfg = vr.start()
        rig = Rig(cfg, clock=vr.clock)
        return rig, vr
    cfg = rig_config.load(args.rig)
    return Rig(cfg), None


def run(args):
    from rig import config as rig_config
    from rig.safety import Safety
    from protocols.display import shown
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
        safety = Safety(cfg)
        where = "embedded virtual rig" if vr is not None else cfg.path
        units = args.units
        print(f"rig {cfg.name!r} ({where})")
        print(f"{'channel':12s} {'device':12s} {'value':>14s} {'unit':5s} {'age':>8s}  status")
        missing = []
        for name, ch in cfg.channels.items():
            r = readings.get(name)
            if r is None:
                missing.append(f"{name} ({ch.device})")
                print(f"{name:12s} {ch.device:12s} {'-':>14s} {shown(0.0, ch.unit, units)[1]:5s} {'-':>8s}  NO DATA")
                continue
            status = "ok" if r.fault is None else f"FAULT: {r.fault}"
            q = rig_config.quantity(name)
            beyond = safety.beyond_limit(name, r.value)
            if r.fault:
                missing.append(f"{name} ({ch.device}: {r.fault})")
            elif q is not None and not q[1] <= r.value <= q[2]:
                (lo, u), (hi, _), (v, _) = (shown(x, unit, units)
                                            for x, unit in ((q[1], q[0]), (q[2], q[0]), (r.value, ch.unit)))
                status = f"IMPLAUSIBLE: outside {lo:g}..{hi:g} {u}: check gain, offset and wiring"
                missing.append(f"{name} ({ch.device}: implausible {v:.6g} {u})")
            elif beyond:
                status = f"BEYOND LIMIT: {beyond}"
                missing.append(f"{name} ({ch.device}: beyond limit)")
            v, u = shown(r.value, ch.unit, units)
            print(f"{name:12s} {ch.device:12s} {v:14.6g} {u:5s} {1e3 * (now - r.t):6.0f} ms  {status}")
        state, alarms = rig.actuator()
        print(f"actuator: {state}, {'alarms: ' + ', '.join(alarms) if alarms else 'no alarms'}")
        if state == "unknown":
            missing.append(f"actuator status ({cfg.actuator})")
        if missing:
            print(f"dyno: error: rig check: no data, faulted or implausible: {', '.join(missing)}", file=sys.stderr)
            return 1
        print(f"all {len(cfg.channels)} channels report")
        return 0
    finally:
        rig.close()
        if vr is not None:
            vr.close()
