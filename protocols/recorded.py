"""A recorded run's plan, checked before anything moves (`planned`), and its life, from the
claim of its recording to the last close (`record`): the cell opened,
the observers attached (the recorder, the live view, live identification and diagnosis),
the plan run (or `dyno run discover`'s rounds), then everything closed in order with every
error kept, the first being the one that ended the run. `dyno run` parses and prints
around it (commands/run.py)."""
from __future__ import annotations

import json
from contextlib import contextmanager
from dataclasses import dataclass, field

from models.damper import to_dict
from rig.errors import RigError, UsageError


def planned(protocol, pairs, damper, rig, plant=None, long=False, rate_hz=None, units=None, budget=None, say=print):
    """(protocol module, params, rig config, RigInfo) of `dyno run PROTOCOL name=value...` on
    the damper (a Damper) and the rig config (a path or name; on the virtual rig with the
    plant's PlantOptions), refused before anything connects or moves: unknown protocol or
    parameters, a simplified damper, the pre-flight's limits, a closed loop's rehearsal (on
    the virtual plant, or the damper model alone on a real cell). What it checked is said."""
    from protocols import preflight, proven
    from protocols.library import DISCOVER, PROTOCOLS
    from protocols.plan import parse, rig_info
    from protocols.rehearsal import AGAINST, rehearse
    from rig import config as rig_config
    module = PROTOCOLS.get("sine-matrix" if protocol == DISCOVER else protocol)
    if module is None:
        raise UsageError(f"unknown protocol {protocol!r} (known: {', '.join(PROTOCOLS)}, {DISCOVER})")
    if budget is not None and protocol != DISCOVER:
        raise UsageError(f"--budget: the rig time of `dyno run {DISCOVER}`'s own tests; {protocol} has none")
    if protocol == DISCOVER:  # the opening: the sine matrix the diagnosis is proven on (protocols/proven.toml)
        pairs = [*pairs, *(f"{k}={','.join(f'{x:g}' for x in v) if isinstance(v, list) else v}"
                           for k, v in proven.opening()[1].items() if not any(p.startswith(f"{k}=") for p in pairs))]
    params = parse(module.Params, pairs)
    if damper.layout == "simplified":
        raise UsageError(f"{damper.name}: a simplified model (eq 6.1/6.2) has no geometry or gas spring to run on a "
                         f"rig; give a full damper (a preset or JSON)")
    virtual = plant is not None
    cfg = rig_config.load(rig)
    if rate_hz:  # `dyno prove --rates`: the virtual cell at another loop rate
        cfg = rig_config.at_rate(cfg, rate_hz)
    for channel, what in plant.drives().items() if virtual else ():
        if channel in cfg.channels:  # the recording says the channel drives the damper
            cfg = rig_config.driven(cfg, channel, what)
    info = rig_info(cfg, damper)
    for name, why in module.check(params, info):  # refused before anything connects or moves
        say(f"skipping {name}: {why}")
    forecast = preflight.check(list(module.plan(params, info)), info, long=long)
    say(preflight.summary(forecast, units))
    if getattr(module, "REHEARSE", False):
        for name, found in rehearse(module, params, cfg, damper, virtual):
            say(f"pre-flight (the run against {AGAINST[virtual]}): {name}: {module.summary(found)}")
    return module, params, cfg, info


def claimed(out, name, inputs, overwrite, identifying):
    """The recording's files.Claim (out, else recordings/NAME-TIME.mcap), taken before the rig
    opens: an existing file refused without overwrite, a target another run is writing
    refused, and the live identification's model file checked with it."""
    from datetime import datetime
    from pathlib import Path

    from records.files import Claim, numbered, output_file
    claim = Claim(out or numbered(Path("recordings") / f"{name}-{datetime.now():%Y%m%d-%H%M%S}.mcap"),
                  overwrite=overwrite, inputs=inputs)
    if identifying:
        try:
            output_file(claim.target.with_suffix(".model.json"), inputs, overwrite, "--identify")
        except UsageError:
            claim.release()
            raise
    return claim


@contextmanager
def held(claim):
    """A claim taken before the pre-flight, so that a second writer is refused at once and not
    after a pre-flight that can outlast the first run; released, its target as it was, if
    anything fails before the run."""
    try:
        yield claim
    except BaseException:
        if claim:
            claim.abandon()
            claim.release()
        raise


def for_run(path, cell, plan, run_info=None, overwrite=False):
    """The recorder (records/recorder.py) of a plan run on a cell (protocols/cell.py): its
    damper, protocol and parameters, on the rig's clock; run_info as `dyno run` gives it
    (damper_serial, note...). Close it after the run (contextlib.closing)."""
    from protocols.plan import as_dict
    from records.recorder import Recorder
    return Recorder(path, cell.config, json.dumps(to_dict(cell.damper)), plan.name, as_dict(plan.params),
                    wall_start=cell.rig.wall_start, overwrite=overwrite, run_info=run_info)


@dataclass
class Run:
    module: object  # the protocol (protocols/library/)
    params: object  # its Params
    protocol: str  # as asked: the module's NAME, or discover
    damper: object  # Damper
    claim_of: callable  # () -> files.Claim: the recording, taken before the cell opens
    open_cell: callable  # (config) -> Cell, open
    config: object  # RigConfig
    identify: bool = False  # a model of the damper while it runs (RECORDING.model.json)
    diagnose: bool = False  # each sine segment diagnosed as it ends
    live: bool = False  # a rerun viewer spawned
    rrd: str | None = None  # the live view saved
    budget: float | None = None  # discover: rig time for its own tests [s]
    units: object = None  # the progress line's units
    progress: bool = True
    run_info: dict = field(default_factory=dict)  # who tested which damper
    say: callable = print  # what the run says as it starts (the recording's path, discover's rounds)


@dataclass
class Ended:
    result: object  # runner.RunResult (None: the run never started)
    cell: object
    claim: object
    recorder: object
    identification: object  # LiveIdentify, or None
    errors: list  # the first ended the run; later ones were met closing


def record(run: Run) -> Ended:
    """Run it, recorded; RigError when it never started (nothing moved, nothing recorded)."""
    from records.recorder import Recorder
    from protocols.library import DISCOVER
    from protocols.plan import Plan, as_dict
    from protocols.runner import run_plan
    from rig import operator_stop
    claim = c = recorder = live = ident = diag = result = None
    errors = []
    try:
        with operator_stop.quiet():  # the claim taken and held in `claim` together: a stop releases it
            claim = run.claim_of()
        c = run.open_cell(run.config)
        cfg = c.config
        if run.live or run.rrd:
            from protocols.live import LiveView
            live = LiveView({n: ch.unit for n, ch in cfg.channels.items()}, spawn=run.live, rrd=run.rrd)
        recorder = Recorder(claim, cfg, json.dumps(to_dict(run.damper)), run.protocol, as_dict(run.params),
                            wall_start=c.rig.wall_start, run_info=run.run_info)
        run.say(f"recording to {claim.target}")
        operator_stop.raise_if_stopped()
        if run.identify:
            from protocols.live_identify import LiveIdentify
            ident = LiveIdentify(to_dict(run.damper), claim.target.with_suffix(".model.json"), live,
                                 real_time=c.paced)
        if run.diagnose:
            from protocols.live_diagnose import LiveDiagnose
            diag = LiveDiagnose(to_dict(run.damper), recorder, live, real_time=c.paced)
        if run.protocol == DISCOVER:
            from protocols.discover import discover  # the diagnosis and scipy.optimize: only here
            found = discover(Plan(run.module, run.params), c, [recorder, live, ident, diag], run.budget,
                             say=lambda line: run.say(f"discover: {line}"))
            result = found.result
        else:
            result = run_plan(Plan(run.module, run.params), c, [recorder, live, ident, diag],
                              progress=run.progress, units=run.units)
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
    if result.fault:
        errors.insert(0, result.fault)
    return Ended(result, c, claim, recorder, ident, errors)
