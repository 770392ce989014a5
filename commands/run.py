"""`dyno run PROTOCOL [name=value ...]`: a protocol on the embedded virtual rig, a wired
cell (--rig) or the direct one (--rig direct), pre-flight checked, recorded to MCAP, with
the live view and identification as observers."""
from __future__ import annotations

import argparse
import functools
import sys

from models.damper import load as load_damper
from commands.arguments import (BUDGET_S, FILE, MAX_BUDGET_S, hidden_physics, identity, identity_info, number,
                                units, virtual_plant, writes)
from rig.errors import UsageError

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
    from protocols.library import DISCOVER, PROTOCOLS
    from protocols.recorded import Run, claimed, held, record
    with operator_stop.handled():  # dyno's main sets it too; a cluster worker's thread has none
        name = getattr(PROTOCOLS.get("sine-matrix" if args.protocol == DISCOVER else args.protocol), "NAME", None)
        identifying = args.identify if args.identify is not None else name == "standard"
        with held(name and claimed(args.out, name, _inputs(args), args.overwrite, identifying)) as claim:
            module, params, plant, damper, cfg, _ = _plan_run(args)  # unknown protocol (no claim): said here
            operator_stop.raise_if_stopped()
        ended = record(Run(module, params, args.protocol, damper, lambda: claim,
                           lambda config: open_cell(args, config, damper, plant), cfg, identify=identifying,
                           diagnose=getattr(args, "diagnose", False), live=args.live, rrd=args.rrd,
                           budget=args.budget, units=args.units, progress=getattr(args, "progress", True),
                           run_info=identity_info(args), say=lambda line: print(line, file=sys.stderr, flush=True)))
        return _finish_run(module, args.protocol, ended)


def _plan_run(args):
    """What a run needs, checked before anything connects or moves: (module, params, plant, damper, config, RigInfo)."""
    from records.files import output_file
    from protocols.library import DISCOVER
    from protocols.recorded import planned
    given = [f"{n}={getattr(args, n)}" for n in ("car", "road", "compensator", "target", "iterations")
             if getattr(args, n, None) is not None]
    if args.protocol == DISCOVER:
        args.budget = BUDGET_S if args.budget is None else args.budget
    virtual = args.rig in (None, DIRECT)
    if not virtual and (args.effect or args.plain):
        raise UsageError("--effect and --plain hide physics in the virtual rig: not with --rig")
    if args.rig == DIRECT and args.realtime:
        raise UsageError(f"--realtime: the {DIRECT} cell runs on its simulated clock (the embedded rig keeps real "
                         f"time)")
    plant = virtual_plant(args) if virtual else None  # a real cell opens no file of the simulator
    damper = load_damper(plant.damper if virtual else args.damper)
    if args.rrd:
        output_file(args.rrd, _inputs(args), args.overwrite, "--rrd")
    module, params, cfg, info = planned(args.protocol, [*args.params, *given], damper, "virtual" if virtual else args.rig,
                                        plant, long=args.long, rate_hz=getattr(args, "rate_hz", None),
                                        units=args.units, budget=args.budget,
                                        say=lambda line: print(line, file=sys.stderr))
    return module, params, plant, damper, cfg, info


def open_cell(args, cfg, damper, plant):
    """The embedded virtual rig unless --rig names a cell or the direct one (protocols/cell.py), open."""
    from protocols import cell
    if args.rig is None:
        return cell.embedded(damper, cfg, realtime=args.realtime, plant=plant)
    if args.rig == DIRECT:
        return cell.direct(cfg, damper, plant)
    return cell.wired(cfg, damper)


def _finish_run(module, name, ended):
    """Say what was recorded and what stopped it, finish the live identification; the exit status."""
    from views import run_index
    c, result, errors, ident = ended.cell, ended.result, ended.errors, ended.identification
    say = functools.partial(print, file=sys.stderr, flush=True)
    if ended.recorder.kept:
        say(f"recorded {result.duration_s:.1f} s of {name} to {ended.recorder.path}; {run_index.add(ended.recorder.path)}")
    else:
        target = ended.claim.target
        say(f"nothing recorded: the run stopped before its first segment; {target} "
            f"{'kept as it was' if target.exists() else 'not written'}")
    if c.paced and result.ticks:
        late = sum(1 for x in result.lateness_s if x > 1.0 / c.config.rate_hz)
        say(f"real time: {late} of {result.ticks} ticks late by more than a period "
            f"(worst {1e3 * max(result.lateness_s):.1f} ms, {result.missed} skipped)")
        if c.config.realtime_priority and not result.sched_fifo:
            say(f"real time: rig.realtime_priority {c.config.realtime_priority} refused by the OS (it needs root or "
                "an rtprio limit): the loop ran at normal priority")
    for segment, found in result.measures:
        say(f"{segment}: {module.summary(found)}")
    for later in errors[1:]:
        say(f"dyno: also: {later}")
    if ident is not None and ended.recorder.kept:
        say("identify: final fit of the whole recording (the rig is already safe)")
        model = ident.finish()
        if model:
            say(f"identify: model written to {model}")
    elif ident is not None:
        ident.cancel()
    if errors:
        say(f"dyno: run stopped: {errors[0]}")
        return 130 if errors[0] == "operator stop" else 1
    return 0


def _inputs(args):  # the files a run reads: no output may be one of them
    from rig import config as rig_config
    from records.files import existing_files
    rig = args.rig not in (None, DIRECT) and str(rig_config.path_of(args.rig))
    return existing_files(args.damper, rig, args.params, *(getattr(args, n, None) for n in ("car", "road", "target")))
