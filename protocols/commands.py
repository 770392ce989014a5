"""The `dyno` commands for the cell: sim-rig, rig check, run, recover, report."""
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


def virtual_plant(args):
    """VirtualRig keywords from --damper, --effect, --plain and --seed."""
    from sim_backend.effects import EffectError, parse, plain_cell
    try:
        effects = parse(args.effect)
    except EffectError as e:
        raise RigError(str(e)) from None
    params = None
    damper = args.damper
    if args.plain:
        name, params, _ = plain_cell()
        damper = name if damper in (None, "koni") else damper
    return {"damper": damper, "effects": effects, "params": params, "seed": args.seed}


def sim_rig(args):
    from sim_backend.virtual_rig import VirtualRig
    faults = parse_faults(args.fault)
    cfg = rig_config.load(args.config)
    vr = VirtualRig(cfg, **virtual_plant(args))
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


def rig_info(cfg, damper):
    """RigInfo for the plans: the damper's mid-stroke (or the safe position without a
    model), the rig's limits, the damper model's peak force for the pre-flight check."""
    import numpy as np

    from models.simulate import simulate
    from protocols.plan import RigInfo
    L = cfg.limits
    peak = None
    x_mid, x_min, x_max = cfg.safe_position, L["x_min"], L["x_max"]
    if damper is not None and getattr(damper, "layout", "") != "simplified":
        x_mid = damper.mid_stroke
        # never plan into the damper's own end stops: 2 mm inside its stroke at most
        x_min, x_max = max(x_min, 0.002), min(x_max, damper.geometry.stroke - 0.002)

        def peak_force(v, d=damper):
            # the damper may be cold (ambient) or at its reference temperature: the larger
            r = [simulate(d, np.array([0.0, 1.0]), np.array([d.mid_stroke] * 2), v=np.array([v, -v]),
                          T=T, compressible=False) for T in (293.15, d.temperature.T_ref)]
            return float(max(np.max(np.abs(x.force)) for x in r))
        peak = peak_force
    return RigInfo(x_mid, x_min, x_max, L["velocity_max"], L.get("frequency_max", 50.0),
                   L["force_max"], L["temperature_max"], 293.15, peak)


def run_protocol(args):
    import json as _json
    from datetime import datetime
    from pathlib import Path

    from models.damper import load as load_damper
    from models.damper import to_dict
    from protocols import runner
    from protocols.library import PROTOCOLS
    from protocols.plan import as_dict, parse
    from protocols.recording import Recorder
    from rig.loop import RealTimePacer, SimulatedPacer
    from rig.safety import Safety

    module = PROTOCOLS.get(args.protocol)
    if module is None:
        raise RigError(f"unknown protocol {args.protocol!r} (known: {', '.join(PROTOCOLS)})")
    params = parse(module.Params, args.params)
    if args.rig is not None and (args.effect or args.plain):
        raise RigError("--effect and --plain hide physics in the virtual rig: not with --rig")
    plant = virtual_plant(args)
    damper = load_damper(plant.pop("damper"))
    cfg = rig_config.load(args.rig) if args.rig else rig_config.load("virtual")
    info = rig_info(cfg, damper)
    skipped = module.check(params, info)  # refuse before anything connects or moves
    for name, why in skipped:
        print(f"skipping {name}: {why}", file=sys.stderr)
    identifying = args.identify if args.identify is not None else module.NAME == "standard"
    if identifying and (damper.layout == "simplified"):
        identifying = False
    out = Path(args.out) if args.out else Path("recordings") / f"{module.NAME}-{datetime.now():%Y%m%d-%H%M%S}.mcap"
    out.parent.mkdir(parents=True, exist_ok=True)
    vr = None
    if args.rig is None:
        from sim_backend.virtual_rig import VirtualRig
        vr = VirtualRig(cfg, damper=damper, **plant)
        cfg = vr.start()
        rig = Rig(cfg, clock=vr.clock)
        pacer = RealTimePacer(cfg.rate_hz, virtual_rig=vr) if args.realtime else SimulatedPacer(vr, cfg.rate_hz)
    else:
        rig = Rig(cfg)
        pacer = RealTimePacer(cfg.rate_hz)
    recorder = live = ident = None
    previous = signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    try:
        rig.open()
        if args.live or args.rrd:
            from protocols.live import LiveView
            live = LiveView({n: c.unit for n, c in cfg.channels.items()}, spawn=args.live, rrd=args.rrd)
        recorder = Recorder(out, cfg, _json.dumps(to_dict(damper)), module.NAME, as_dict(params))
        print(f"recording to {out}", file=sys.stderr, flush=True)
        if identifying:
            from protocols.live_identify import LiveIdentify
            ident = LiveIdentify(to_dict(damper), out.with_suffix(".model.json"), live)
        result, _ = runner.run(module, params, info, rig, pacer, Safety(cfg), [recorder, live, ident],
                               progress=getattr(args, "progress", True))
    finally:
        signal.signal(signal.SIGTERM, previous)
        if recorder is not None:
            recorder.close()
        if live is not None:
            live.close()
        rig.close()
        if vr is not None:
            vr.close()
    print(f"recorded {result.duration_s:.1f} s of {module.NAME} to {out}", file=sys.stderr)
    if ident is not None:
        print("identify: final fit of the whole recording (the rig is already safe)", file=sys.stderr, flush=True)
        model = ident.finish()
        if model:
            print(f"identify: model written to {model}", file=sys.stderr)
    if result.fault:
        print(f"dyno: run stopped: {result.fault}", file=sys.stderr)
        return 130 if result.fault == "operator stop" else 1
    return 0


def recover_file(args):
    from protocols.recording import recover
    r = recover(args.file)
    if r["intact"]:
        print(f"{args.file}: intact, nothing to recover")
    else:
        print(f"{args.file}: recovered {r['messages']} messages, {r['metadata']} metadata, "
              f"{r['attachments']} attachments; the damaged original is {r['damaged']}")
    return 0


def report_file(args):
    from protocols.report import report
    index, pngs = report(args.file, args.out)
    for p in pngs:
        print(p)
    print(index)
    return 0
