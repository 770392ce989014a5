"""`dyno run PROTOCOL [name=value ...]`: a protocol on the embedded virtual rig, a wired
cell (--rig) or the direct one (--rig direct), pre-flight checked, recorded to MCAP, with
the live view and identification as observers."""
from __future__ import annotations

import argparse
import json
import sys

from models.damper import load as load_damper
from models.damper import to_dict
from protocols.errors import UsageError
from rig.errors import RigError

from protocols.app.arguments import (BUDGET_S, FILE, MAX_BUDGET_S, hidden_physics, identity, identity_info, number,
                                     units, virtual_plant, writes)

DIRECT = "direct"  # --rig: the virtual plant without its wires (protocols/cell.py direct)


def add(sub):
    """The `dyno run` command's arguments."""
    rn = sub.add_parser("run", help="run a test protocol and record it to MCAP",
                        epilog="dyno run PROTOCOL --help lists its parameters; dyno protocols lists the protocols")
    rn.add_argument("protocol", help="static, low-speed, sine-matrix, temperature-sweep, step, standard, hil, replay; "
                                     "discover: a sine matrix, then the tests the diagnosis asks for")
    rn.add_argument("params", nargs="*", metavar="name=value", help="protocol parameters (lists comma-separated)")
    rn.add_argument("--rig", default=None, help=f"rig config (default: the embedded virtual rig); {DIRECT}: the virtual "
                                                "plant without its wires, on its simulated clock (several times "
                                                "faster, no transport's timing: a study, not a cell)")
    rn.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    hidden_physics(rn)
    writes(rn, "--out", FILE, default=None, help="recording FILE.mcap (default recordings/PROTOCOL-TIME.mcap); "
                                                "an existing file is kept unless --overwrite")
    rn.add_argument("--overwrite", action="store_true", help="replace an existing --out file once the run starts")
    rn.add_argument("--long", action="store_true", help="allow a run planned to move for more than 2 hours")
    units(rn)
    rn.add_argument("--realtime", action="store_true", help="run the virtual rig in real time")
    rn.add_argument("--live", action="store_true", help="stream to a rerun viewer")
    writes(rn, "--rrd", FILE, default=None, help="also save the live view to FILE.rrd")
    identity(rn)
    rn.add_argument("--budget", type=number(0, MAX_BUDGET_S), default=None, metavar="SECONDS",
                    help="discover: rig time the dyno may add for its own next tests (default 120)")
    rn.add_argument("--identify", action=argparse.BooleanOptionalAction, default=None,
                    help="identify the damper while the test runs and write RECORDING.model.json "
                         "(default: on for the standard sequence)")
    rn.add_argument("--diagnose", action="store_true",
                    help="diagnose each sine segment as it ends, against the damper's model: the findings go into "
                         "the recording, the live view and here")
    for name, what in (("car", "hil: quarter-car preset (simulator, simulator-9kg, race-car) or FILE.json"),
                       ("road", "hil: step:MM, sine:HZ:MM, sweep:F0:F1:MM, iso8608:CLASS:KMH[:SECONDS], file:CSV"),
                       ("compensator", "hil: actuator delay compensation: none, polynomial, adaptive"),
                       ("target", "replay: CSV of time [s], displacement [mm] about mid-stroke"),
                       ("iterations", "replay: drive corrections to make (default 5)")):
        rn.add_argument(f"--{name}", default=None, help=what + " (the same as " + name + "=...)")
    rn.set_defaults(command="run")


def run(args):
    from rig import operator_stop
    with operator_stop.handled():  # dyno's main sets it too; a cluster worker's thread has none
        return _run(args)


def _run(args):
    from rig import operator_stop
    from protocols.io.recording import Recorder
    from protocols.library import DISCOVER
    from protocols.plan import Plan, as_dict
    from protocols.runner import run_plan
    module, params, plant, damper, cfg, info = _plan_run(args)
    operator_stop.raise_if_stopped()
    identifying = args.identify if args.identify is not None else module.NAME == "standard"
    claim = c = recorder = live = ident = diag = result = None
    errors = []  # the first is the one that ended the run; later ones are reported after it
    try:
        with operator_stop.quiet():  # the claim taken and held in `claim` together: a stop releases it
            claim = _output(args, module.NAME, identifying)
        c = open_cell(args, cfg, damper, plant)
        cfg = c.config
        if args.live or args.rrd:
            from protocols.live import LiveView
            live = LiveView({n: c.unit for n, c in cfg.channels.items()}, spawn=args.live, rrd=args.rrd)
        recorder = Recorder(claim, cfg, json.dumps(to_dict(damper)), args.protocol, as_dict(params),
                            wall_start=c.rig.wall_start, run_info=identity_info(args))
        print(f"recording to {claim.target}", file=sys.stderr, flush=True)
        operator_stop.raise_if_stopped()
        if identifying:
            from protocols.live_identify import LiveIdentify
            ident = LiveIdentify(to_dict(damper), claim.target.with_suffix(".model.json"), live,
                                 real_time=c.paced)
        if getattr(args, "diagnose", False):
            from protocols.live_diagnose import LiveDiagnose
            diag = LiveDiagnose(to_dict(damper), recorder, live, real_time=c.paced)
        if args.protocol == DISCOVER:
            from protocols.discover import discover  # the diagnosis and scipy.optimize: only here
            found = discover(Plan(module, params), c, [recorder, live, ident, diag], args.budget,
                             say=lambda line: print(f"discover: {line}", file=sys.stderr, flush=True))
            result = found.result
        else:
            result = run_plan(Plan(module, params), c, [recorder, live, ident, diag],
                              progress=getattr(args, "progress", True), units=args.units)
        if diag is not None:  # the last segments' findings, into the recording before it closes
            diag.finish()
    except KeyboardInterrupt:
        errors.append("operator stop")
    except (RigError, UsageError) as e:
        if claim is None:
            raise
        errors.append(str(e))
    finally:
        if diag is not None:
            diag.cancel()
        for close in (recorder and recorder.close, live and live.close, c and c.close):
            if close:
                try:
                    close()
                except Exception as e:  # noqa: BLE001 - never hides the error that ended the run
                    errors.append(str(e) if isinstance(e, RigError) else f"{type(e).__name__}: {e}")
        if recorder is None and claim is not None:
            claim.abandon()
            claim.release()
    if result is None:  # the run never started: nothing moved, nothing recorded
        if ident is not None:
            ident.cancel()
        raise RigError(errors[0] if errors else "run did not start")
    return _finish_run(module, args.protocol, c, claim, recorder, result, errors, ident)


def _plan_run(args):
    """What a run needs, checked before anything connects or moves: (protocol module,
    params, virtual plant options, damper, rig config, RigInfo)."""
    from rig import config as rig_config
    from protocols import preflight, proven
    from protocols.io.files import output_file
    from protocols.library import DISCOVER, PROTOCOLS
    from protocols.plan import parse, rig_info
    from protocols.rehearsal import AGAINST, rehearse
    module = PROTOCOLS.get("sine-matrix" if args.protocol == DISCOVER else args.protocol)
    if module is None:
        raise UsageError(f"unknown protocol {args.protocol!r} (known: {', '.join(PROTOCOLS)}, {DISCOVER})")
    given = [f"{n}={getattr(args, n)}" for n in ("car", "road", "compensator", "target", "iterations")
             if getattr(args, n, None) is not None]
    pairs = args.params
    if args.budget is not None and args.protocol != DISCOVER:
        raise UsageError(f"--budget: the rig time of `dyno run {DISCOVER}`'s own tests; {args.protocol} has none")
    if args.protocol == DISCOVER:
        args.budget = BUDGET_S if args.budget is None else args.budget
        # the opening: the sine matrix the diagnosis is proven on (protocols/proven.toml), name=value overriding
        given = [f"{k}={','.join(f'{x:g}' for x in v) if isinstance(v, list) else v}"
                 for k, v in proven.opening()[1].items() if not any(p.startswith(f"{k}=") for p in pairs)]
    params = parse(module.Params, [*pairs, *given])
    virtual = args.rig in (None, DIRECT)
    if not virtual and (args.effect or args.plain):
        raise UsageError("--effect and --plain hide physics in the virtual rig: not with --rig")
    if args.rig == DIRECT and args.realtime:
        raise UsageError(f"--realtime: the {DIRECT} cell runs on its simulated clock (the embedded rig keeps real "
                         f"time)")
    plant = virtual_plant(args) if virtual else None  # a real cell opens no file of the simulator
    damper = load_damper(plant.damper if virtual else args.damper)
    if damper.layout == "simplified":
        raise UsageError(f"{damper.name}: a simplified model (eq 6.1/6.2) has no geometry or gas spring to run on a "
                       f"rig; give a full damper (a preset or JSON)")
    if args.rrd:
        output_file(args.rrd, _inputs(args), args.overwrite, "--rrd")
    cfg = rig_config.load("virtual" if virtual else args.rig)
    if getattr(args, "rate_hz", None):  # `dyno prove --rates`: the virtual cell at another loop rate
        cfg = rig_config.at_rate(cfg, args.rate_hz)
    for channel, what in plant.drives().items() if virtual else ():
        if channel in cfg.channels:  # the recording says the channel drives the damper
            cfg = rig_config.driven(cfg, channel, what)
    info = rig_info(cfg, damper)
    skipped = module.check(params, info)  # refuse before anything connects or moves
    for name, why in skipped:
        print(f"skipping {name}: {why}", file=sys.stderr)
    forecast = preflight.check(list(module.plan(params, info)), info, long=args.long)
    print(preflight.summary(forecast, args.units), file=sys.stderr)
    if getattr(module, "REHEARSE", False):
        for name, found in rehearse(module, params, cfg, damper, virtual):
            print(f"pre-flight (the run against {AGAINST[virtual]}): {name}: {module.summary(found)}",
                  file=sys.stderr)
    return module, params, plant, damper, cfg, info


def open_cell(args, cfg, damper, plant):
    """The embedded virtual rig unless --rig names a cell or the direct one (protocols/cell.py), open."""
    from protocols import cell
    if args.rig is None:
        return cell.embedded(damper, cfg, realtime=args.realtime, plant=plant)
    if args.rig == DIRECT:
        return cell.direct(cfg, damper, plant)
    return cell.wired(cfg, damper)


def _finish_run(module, name, c, claim, recorder, result, errors, ident):
    """Say what was recorded and what stopped it, finish the live identification; the exit
    status."""
    from protocols import catalogue
    if result.fault:
        errors.insert(0, result.fault)
    if recorder.kept:
        print(f"recorded {result.duration_s:.1f} s of {name} to {recorder.path}; {catalogue.add(recorder.path)}",
              file=sys.stderr)
    else:
        print(f"nothing recorded: the run stopped before its first segment; {claim.target} "
              f"{'kept as it was' if claim.target.exists() else 'not written'}", file=sys.stderr)
    if c.paced and result.ticks:
        late = sum(1 for x in result.lateness_s if x > 1.0 / c.config.rate_hz)
        print(f"real time: {late} of {result.ticks} ticks late by more than a period "
              f"(worst {1e3 * max(result.lateness_s):.1f} ms, {result.missed} skipped)", file=sys.stderr)
        if c.config.realtime_priority and not result.sched_fifo:
            print(f"real time: rig.realtime_priority {c.config.realtime_priority} refused by the OS (it needs root or "
                  "an rtprio limit): the loop ran at normal priority", file=sys.stderr)
    for name, found in result.measures:
        print(f"{name}: {module.summary(found)}", file=sys.stderr)
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


def _inputs(args):
    """The files a run reads: no output may be one of them."""
    from rig import config as rig_config
    from protocols.io.files import existing_files
    rig = args.rig not in (None, DIRECT) and str(rig_config.path_of(args.rig))
    return existing_files(args.damper, rig, args.params, *(getattr(args, n, None) for n in ("car", "road", "target")))


def _output(args, name, identifying):
    """The recording's Claim, taken before the rig opens (refuses an existing file without
    --overwrite, and a target another run is writing)."""
    from protocols.io.files import Claim, numbered, output_file
    from datetime import datetime
    from pathlib import Path

    inputs = _inputs(args)
    claim = Claim(args.out or numbered(Path("recordings") / f"{name}-{datetime.now():%Y%m%d-%H%M%S}.mcap"),
                  overwrite=args.overwrite, inputs=inputs)
    if identifying:
        try:
            output_file(claim.target.with_suffix(".model.json"), inputs, args.overwrite, "--identify")
        except UsageError:
            claim.release()
            raise
    return claim
