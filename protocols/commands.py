"""The `dyno` commands for the cell: sim-rig, rig check, run, recover, report."""
from __future__ import annotations

import math
import signal
import sys
import threading
import time

from rig import config as rig_config
from rig.devices import TRANSPORTS
from rig.errors import RigError
from rig.rig import Rig
from rig.safety import Safety

from protocols.files import writable_file

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
        safety = Safety(cfg)
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
            q = rig_config.quantity(name)
            beyond = safety.beyond_limit(name, r.value)
            if r.fault:
                missing.append(f"{name} ({ch.device}: {r.fault})")
            elif q is not None and not q[1] <= r.value <= q[2]:
                status = f"IMPLAUSIBLE: outside {q[1]:g}..{q[2]:g} {q[0]}: check gain, offset and wiring"
                missing.append(f"{name} ({ch.device}: implausible {r.value:.6g} {ch.unit})")
            elif beyond:
                status = f"BEYOND LIMIT: {beyond}"
                missing.append(f"{name} ({ch.device}: beyond limit)")
            print(f"{name:12s} {ch.device:12s} {r.value:14.6g} {ch.unit:5s} {1e3 * (now - r.t):6.0f} ms  {status}")
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
            t = math.nan
        if not (math.isfinite(t) and t >= 0):
            raise RigError(f"--fault {spec}: the time after @ must be seconds from the start (0 or more)")
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


def rig_info(cfg, damper):
    """RigInfo for the plans: the damper's mid-stroke (or the safe position without a
    model), the rig's limits, the damper model's response for the pre-flight check."""
    import numpy as np

    from models.physics.simulate import simulate
    from protocols.plan import RigInfo
    L = cfg.limits
    peak = response = None
    x_mid, x_min, x_max = cfg.safe_position, L["x_min"], L["x_max"]
    ambient = cfg.thermal.get("ambient", 293.15)
    if damper is not None and getattr(damper, "layout", "") != "simplified":
        x_mid = damper.mid_stroke
        # never plan into the damper's own end stops: 2 mm inside its stroke at most
        x_min, x_max = max(x_min, 0.002), min(x_max, damper.geometry.stroke - 0.002)
        temps = (ambient, damper.temperature.T_ref)  # cold or at its reference: the larger force

        def peak_force(v, d=damper):
            r = [simulate(d, np.array([0.0, 1.0]), np.array([d.mid_stroke] * 2), v=np.array([v, -v]),
                          T=T, compressible=False) for T in temps]
            return float(max(np.max(np.abs(x.force)) for x in r))

        def response(t, x, v, T, d=damper):
            """Force and gas pressure along a motion at T [K], or (T None) the worse force
            of cold and reference and the gas of a damper that has not warmed."""
            runs = [simulate(d, t, x, v=v, T=Ti, compressible=False, x_e=d.mid_stroke)
                    for Ti in ((T,) if T is not None else temps)]
            worst = max(runs, key=lambda r: np.max(np.abs(r.force)))
            return worst.force, runs[0].P_gas
        peak = peak_force
    return RigInfo(x_mid, x_min, x_max, L["velocity_max"], L.get("frequency_max", 50.0),
                   L["force_max"], L["temperature_max"], ambient, peak, response, L["gas_pressure_max"],
                   cfg.thermal.get("conductance"))


def _output(args, name):
    """The recording's Claim, taken before the rig opens (refuses an existing file without
    --overwrite, and a target another run is writing)."""
    from datetime import datetime
    from pathlib import Path

    from protocols.files import Claim, numbered
    if args.out:
        return Claim(args.out, overwrite=args.overwrite)
    default = Path("recordings") / f"{name}-{datetime.now():%Y%m%d-%H%M%S}.mcap"
    return Claim(numbered(default))


def run_protocol(args):
    import json as _json

    from models.damper import to_dict
    from protocols import runner
    from protocols.plan import as_dict
    from protocols.recording import Recorder

    module, params, plant, damper, cfg, info = _plan_run(args)
    identifying = args.identify if args.identify is not None else module.NAME == "standard"
    claim = _output(args, module.NAME)
    vr = rig = recorder = live = ident = result = pacer = None
    errors = []  # the first is the one that ended the run; later ones are reported after it
    previous = signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    try:
        vr, rig, cfg, pacer = _open_rig(args, cfg, damper, plant)
        if args.live or args.rrd:
            from protocols.live import LiveView
            live = LiveView({n: c.unit for n, c in cfg.channels.items()}, spawn=args.live, rrd=args.rrd)
        recorder = Recorder(claim, cfg, _json.dumps(to_dict(damper)), module.NAME, as_dict(params),
                            wall_start=rig.wall_start)
        print(f"recording to {claim.target}", file=sys.stderr, flush=True)
        if identifying:
            from protocols.live_identify import LiveIdentify
            ident = LiveIdentify(to_dict(damper), claim.target.with_suffix(".model.json"), live)
        result, _ = runner.run(module, params, info, rig, pacer, Safety(cfg), [recorder, live, ident],
                               progress=getattr(args, "progress", True))
    except KeyboardInterrupt:
        errors.append("operator stop")
    except RigError as e:
        errors.append(str(e))
    finally:
        signal.signal(signal.SIGTERM, previous)
        for close in (recorder and recorder.close, live and live.close, rig and rig.close, vr and vr.close):
            if close:
                try:
                    close()
                except Exception as e:  # noqa: BLE001 - never hides the error that ended the run
                    errors.append(str(e) if isinstance(e, RigError) else f"{type(e).__name__}: {e}")
        if recorder is None:
            claim.abandon()
            claim.release()
    if result is None:  # the run never started: nothing moved, nothing recorded
        if ident is not None:
            ident.cancel()
        raise RigError(errors[0] if errors else "run did not start")
    return _finish_run(module, cfg, claim, recorder, pacer, result, errors, ident)


def _plan_run(args):
    """What a run needs, checked before anything connects or moves: (protocol module,
    params, virtual plant options, damper, rig config, RigInfo)."""
    from models.damper import load as load_damper
    from protocols import preflight
    from protocols.library import PROTOCOLS
    from protocols.plan import parse

    module = PROTOCOLS.get(args.protocol)
    if module is None:
        raise RigError(f"unknown protocol {args.protocol!r} (known: {', '.join(PROTOCOLS)})")
    params = parse(module.Params, args.params)
    if args.rig is not None and (args.effect or args.plain):
        raise RigError("--effect and --plain hide physics in the virtual rig: not with --rig")
    plant = virtual_plant(args)
    damper = load_damper(plant.pop("damper"))
    if damper.layout == "simplified":
        raise RigError(f"{damper.name}: a simplified model (eq 6.1/6.2) has no geometry or gas spring to run on a "
                       f"rig; give a full damper (a preset or JSON)")
    if args.rrd:
        writable_file(args.rrd, "--rrd")
    cfg = rig_config.load(args.rig) if args.rig else rig_config.load("virtual")
    info = rig_info(cfg, damper)
    skipped = module.check(params, info)  # refuse before anything connects or moves
    for name, why in skipped:
        print(f"skipping {name}: {why}", file=sys.stderr)
    forecast = preflight.check(list(module.plan(params, info)), info, long=args.long)
    print(preflight.summary(forecast), file=sys.stderr)
    return module, params, plant, damper, cfg, info


def _open_rig(args, cfg, damper, plant):
    """(virtual rig or None, open Rig, config as served, pacer): the embedded virtual rig
    unless --rig names a cell."""
    from rig.pacing import RealTimePacer, SimulatedPacer
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
    try:
        rig.open()
    except BaseException:
        for close in (rig.close, vr and vr.close):
            if close:
                try:
                    close()
                except Exception:  # noqa: BLE001 - the open's error is the one to report
                    pass
        raise
    return vr, rig, cfg, pacer


def _finish_run(module, cfg, claim, recorder, pacer, result, errors, ident):
    """Say what was recorded and what stopped it, finish the live identification; the exit
    status."""
    from rig.pacing import RealTimePacer
    if result.fault:
        errors.insert(0, result.fault)
    if recorder.kept:
        print(f"recorded {result.duration_s:.1f} s of {module.NAME} to {recorder.path}", file=sys.stderr)
    else:
        print(f"nothing recorded: the run stopped before its first segment; {claim.target} "
              f"{'kept as it was' if claim.target.exists() else 'not written'}", file=sys.stderr)
    if isinstance(pacer, RealTimePacer) and result.ticks:
        late = sum(1 for x in result.lateness_s if x > 1.0 / cfg.rate_hz)
        print(f"real time: {late} of {result.ticks} ticks late by more than a period "
              f"(worst {1e3 * max(result.lateness_s):.1f} ms, {result.missed} skipped)", file=sys.stderr)
    for later in errors[1:]:
        print(f"dyno: also: {later}", file=sys.stderr)
    if ident is not None and recorder.kept:
        print("identify: final fit of the whole recording (the rig is already safe)", file=sys.stderr, flush=True)
        model = ident.finish()
        if model:
            print(f"identify: model written to {model}", file=sys.stderr)
    elif ident is not None:
        ident.cancel()
    if errors:
        print(f"dyno: run stopped: {errors[0]}", file=sys.stderr)
        return 130 if errors[0] == "operator stop" else 1
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
    from protocols.files import make_dir
    from protocols.report import report
    make_dir(args.out)
    index, pngs = report(args.file, args.out)
    for p in pngs:
        print(p)
    print(index)
    return 0
