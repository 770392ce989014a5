"""The `dyno` command line: the parser table. Each command is a module of protocols.app,
imported only when it runs. Errors in what the user gave us are one line and exit 2."""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from importlib import metadata

from models.damper import DamperError
from models.parallel import TaskFailed
from protocols.app.arguments import MAX_BUDGET_S, Parser, cluster_option, holdout, number, setup_item, sizes, unit_system
from protocols.app.bench.arguments import add as _bench_commands
from protocols.app.output import check_outputs
from protocols.errors import UsageError
from rig.errors import RigError


def _hidden_physics(p):
    # not listed here: their catalogue's import would cost every dyno command a second
    p.add_argument("--effect", action="append", metavar="NAME=VALUE",
                   help="hide physics in the virtual rig, e.g. compressibility=0.5 (docs/diagnosis.md; an unknown "
                        "NAME lists the effects)")
    p.add_argument("--plain", action="store_true",
                   help="the plain cell dyno prove uses (sim_backend/plain.toml): nothing the minimal model leaves out")
    p.add_argument("--seed", type=number(0, 2**32 - 1, integer=True), default=0,
                   help="the virtual rig's noise seed (default 0)")


FILE, FOLDER = "file", "folder"


def _writes(p, flag, kind, **kw):
    """An option naming a file or folder the command writes: main() checks it by the one
    rule (protocols/io/files.py) before the command starts, whatever the command does."""
    action = p.add_argument(flag, **kw)
    action.writes = kind
    return action


def _overwrite(p, what="the output"):
    p.add_argument("--overwrite", action="store_true",
                   help=f"replace {what} if it exists (never an input; a folder's other files are kept)")


def _units(p):
    p.add_argument("--units", type=unit_system, default="metric", metavar="{si,metric,us}",
                   help="the unit system shown: si (m, m/s, N, Pa, K), metric (mm, mm/s, N, bar gauge, C; the "
                        "default) or us (in, in/s, lbf, psi gauge, F)")


def parser():
    p = Parser(prog="dyno", description="Damper dyno controller and damper model tools")
    p.add_argument("--version", action="version", version=f"dyno {metadata.version('dyno')}")
    sub = p.add_subparsers(dest="cmd", required=True)
    for add in (_model_commands, _cell_commands, _analysis_commands, _catalogue_commands, _bench_commands):
        add(sub)
    p.commands = sub.choices  # {name: its parser}: what a mistyped command is matched against (check_command)
    return p


def _model_commands(sub):
    """The damper model on its own: the thesis validation and plots."""
    v = sub.add_parser("validate", help="reproduce the thesis validation table")
    v.add_argument("--json", action="store_true", help="machine-readable {\"rows\": [...]}")
    v.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    v.add_argument("--sensitivity", action="store_true",
                   help="for each missed step row, the install position that would reconcile it (slower)")
    _writes(v, "--report", FOLDER, metavar="DIR", help="also write the step and ride-height figures there")
    _overwrite(v, "--report's figures")
    v.set_defaults(command="validate")
    pl = sub.add_parser("plot", help="write plots as PNG")
    plsub = pl.add_subparsers(dest="what", required=True)
    pd = plsub.add_parser("damper", help="loops, composite curve, temperature and pressure plots")
    pd.add_argument("damper", help="preset name (koni, mechformance, fox-light, fox-heavy) or FILE.json")
    _writes(pd, "--out", FOLDER, required=True, help="output directory")
    pd.add_argument("--amplitude-mm", type=number(), default=12.7, help="sine amplitude (default 12.7)")
    pd.add_argument("--freq", type=number(), nargs="+", default=[1, 2, 4, 8, 16], help="frequencies in Hz")
    pd.add_argument("--temp", type=number(), default=94.0, help="damper temperature in C (default 94)")
    _overwrite(pd, "the figures in --out")
    pd.set_defaults(command="plot:damper")
    for name, helptext, command in (
            ("quarter-car", "frequency and step responses of a quarter car (6.2)", "plot:quarter_car"),
            ("parametric", "parametric study of one damper (6.3)", "plot:parametric"),
            ("simplified", "simplified models I and II against the comprehensive model (6.4)",
             "plot:simplified")):
        q = plsub.add_parser(name, help=helptext)
        q.add_argument("--damper", default="koni", help="preset name or FILE.json (default koni)")
        q.add_argument("--car", default="race-car" if name == "parametric" else "simulator",
                       help="quarter-car preset (simulator, simulator-9kg, race-car) or FILE.json")
        _writes(q, "--out", FOLDER, required=True, help="output directory")
        _overwrite(q, "the figures in --out")
        q.add_argument("--freq", type=number(), nargs="+", default=None,
                       help="excitation frequencies in Hz (default 1.25-20 in 0.25 Hz steps)")
        if name != "simplified":
            q.add_argument("--amplitude-mm", type=number(), nargs="+", default=[3.2, 12.7],
                           help="road amplitudes in mm (default 3.2 12.7)")
        if name == "quarter-car":
            q.add_argument("--temp", type=number(), default=90.0, help="damper temperature in C (default 90)")
        q.add_argument("--workers", type=number(1, 256, integer=True), default=None,
                       help="processes (default: all cores)")
        cluster_option(q)
        q.set_defaults(command=command)


def _cell_commands(sub):
    """The test cell: serve the virtual rig, run a protocol, recover and report recordings."""
    sr = sub.add_parser("sim-rig", help="serve the virtual rig as its own process (CAN socketcand, pty, Modbus TCP)")
    sr.add_argument("--config", default="sim-rig", help="rig config to serve (default: sim-rig)")
    sr.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    sr.add_argument("--fault", action="append", metavar="NAME[@TIME]", help="inject a fault, at TIME s")
    _hidden_physics(sr)
    sr.add_argument("--seconds", type=number(above=0), default=None, help="stop after this long")
    sr.set_defaults(command="sim_rig")
    sub.add_parser("protocols", help="the test protocols, each in a line").set_defaults(command="protocols_list")
    rn = sub.add_parser("run", help="run a test protocol and record it to MCAP",
                        epilog="dyno run PROTOCOL --help lists its parameters; dyno protocols lists the protocols")
    rn.add_argument("protocol", help="static, low-speed, sine-matrix, temperature-sweep, step, standard, hil, replay; "
                                     "discover: a sine matrix, then the tests the diagnosis asks for")
    rn.add_argument("params", nargs="*", metavar="name=value", help="protocol parameters (lists comma-separated)")
    rn.add_argument("--rig", default=None, help="rig config (default: the embedded virtual rig)")
    rn.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    _hidden_physics(rn)
    _writes(rn, "--out", FILE, default=None, help="recording FILE.mcap (default recordings/PROTOCOL-TIME.mcap); "
                                                "an existing file is kept unless --overwrite")
    rn.add_argument("--overwrite", action="store_true", help="replace an existing --out file once the run starts")
    rn.add_argument("--long", action="store_true", help="allow a run planned to move for more than 2 hours")
    _units(rn)
    rn.add_argument("--realtime", action="store_true", help="run the virtual rig in real time")
    rn.add_argument("--live", action="store_true", help="stream to a rerun viewer")
    _writes(rn, "--rrd", FILE, default=None, help="also save the live view to FILE.rrd")
    rn.add_argument("--operator", default=None, help="who runs the test (recorded, shown on the report)")
    rn.add_argument("--serial", default=None, help="the damper's serial number (recorded, shown on the report)")
    rn.add_argument("--note", default=None, help="a note for the record (setup, clickers, ...)")
    rn.add_argument("--setup", action="append", type=setup_item, default=[], metavar="KEY=VALUE",
                    help="the damper's setup, recorded and shown on the report (repeat: --setup clicks_reb=12 "
                         "--setup gas_bar=10)")
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
    rv = sub.add_parser("recover", help="rebuild a recording cut short (the original is kept as FILE.damaged)")
    rv.add_argument("file")
    rv.set_defaults(command="recover")
    rp = sub.add_parser("report", help="HTML report with plots of a recording, or several compared")
    rp.add_argument("file")
    rp.add_argument("other", nargs="*", help="more recordings: each compared (B, C, ...) with the first (A)")
    rp.add_argument("--model", default=None, help="damper model JSON to overlay (default: FILE.model.json if present)")
    _writes(rp, "--out", FOLDER, required=True, help="output directory")
    rp.add_argument("--speeds", default=None, metavar="V,V,...",
                    help="shaft speeds of the velocity table, in --units' velocity unit (default 0.025-0.5 m/s, "
                         "1-20 in/s)")
    rp.add_argument("--paper", choices=("a4", "letter"), default="a4", help="report.pdf's paper (default a4)")
    _units(rp)
    _overwrite(rp, "the report's files in --out")
    rp.set_defaults(command="report")
    rg = sub.add_parser("rig", help="the test cell")
    rgsub = rg.add_subparsers(dest="what", required=True)
    rc = rgsub.add_parser("check", help="connect to every device and print each channel")
    rc.add_argument("--rig", default=None, help="rig config (default: the embedded virtual rig)")
    rc.add_argument("--damper", default="koni", help="damper in the embedded virtual rig (default koni)")
    _units(rc)
    rc.set_defaults(command="rig_check")
    rz = rgsub.add_parser("zero", help="tare the load cell, reference the position, check the LVT; offsets "
                                       "written to the cell file")
    rz.add_argument("--rig", default=None, help="rig config to zero and write (default: the embedded virtual rig)")
    rz.add_argument("--damper", default="koni", help="damper preset or FILE.json: its mid-stroke is held (default koni)")
    rz.add_argument("--unloaded", action="store_true", help="the damper is disconnected: tare the load cell to zero")
    rz.add_argument("--tare-anyway", action="store_true",
                    help="tare with --unloaded even when the reading looks like the damper's gas force")
    rz.add_argument("--x-mm", type=number(), default=None, help="the true position [mm] at mid-stroke, from a gauge")
    _units(rz)
    rz.set_defaults(command="rig_zero")


def _batch_options(p, what, beside):
    p.add_argument("--batch", nargs="+", metavar="FILE",
                   help=f"many recordings, one task each: {beside} beside each and a summary table")
    _writes(p, "--summary", FILE, default=None, help=f"--batch's summary CSV (default {what}-summary.csv)")
    cluster_option(p)
    p.add_argument("--jobs", type=number(1, 256, integer=True), default=2,
                   help="--batch without --cluster: recordings analysed in parallel (default 2)")


def _catalogue_commands(sub):
    """The run catalogue of a folder of recordings (protocols/catalogue.py)."""
    rs = sub.add_parser("runs", help="find and trend runs: a catalogue of a folder of recordings")
    rsub = rs.add_subparsers(dest="what", required=True)
    ri = rsub.add_parser("index", help="index the folder's recordings (incremental; unreadable files kept as errors)")
    ri.add_argument("dir", nargs="?", default="recordings")
    ri.set_defaults(command="runs:index")
    rl = rsub.add_parser("list", help="the runs, oldest first")
    rl.add_argument("dir", nargs="?", default="recordings")
    rl.add_argument("--serial", help="one damper serial")
    rl.add_argument("--since", help="started on or after this UTC date or time (ISO 8601, e.g. 2026-03-01)")
    rl.add_argument("--protocol", help="one protocol (sine-matrix, standard, ...)")
    rl.add_argument("--where", metavar="EXPR", help='conditions FIELD OP VALUE joined by "and": OP = != < <= > >= ~ '
                    '(contains); FIELD serial, operator, note, damper, protocol, started, duration_s, outcome, ... or '
                    'setup.KEY, e.g. "setup.clicks >= 10 and outcome = completed"')
    rl.add_argument("--json", action="store_true")
    rl.set_defaults(command="runs:list_runs")
    rw = rsub.add_parser("show", help="one run: identity, setup, outcome and its peaks")
    rw.add_argument("id", type=int)
    rw.add_argument("dir", nargs="?", default="recordings")
    rw.add_argument("--json", action="store_true", help="everything in SI, as the catalogue holds it")
    _units(rw)
    rw.set_defaults(command="runs:show")
    re_ = rsub.add_parser("edit", help="correct a run's serial, operator, note or setup KEY=VALUE ('' removes one)")
    for a, kw in (("id", {"type": int}), ("dir", {"nargs": "?", "default": "recordings"}), ("--serial", {}),
                  ("--operator", {}), ("--note", {}), ("--setup", {"action": "append", "type": setup_item, "default": []})):
        re_.add_argument(a, **kw)
    re_.set_defaults(command="runs:edit")
    rt = rsub.add_parser("trend", help="a serial's force at one speed over its runs")
    rt.add_argument("dir", nargs="?", default="recordings")
    rt.add_argument("--serial", required=True)
    rt.add_argument("--quantity", required=True, help="DIRECTION@SPEED, e.g. rebound@0.5m/s or compression@10in/s")
    _writes(rt, "--out", FILE, help="also plot it to this PNG (or .svg, .pdf)")
    _overwrite(rt, "--out")
    _units(rt)
    rt.set_defaults(command="runs:trend")
    sv = sub.add_parser("serve", help="the runs in a browser: table, reports, comparisons, trends, QA, live runs")
    sv.add_argument("dir", nargs="?", default="recordings")
    sv.add_argument("--port", type=number(0, 65535, integer=True), default=8050,
                    help="port on 127.0.0.1 (default 8050; 0 picks a free one)")
    _units(sv)
    sv.set_defaults(command="serve")


def _diagnose_command(sub):
    dg = sub.add_parser("diagnose", help="where the model misses a recording and what physics was left out")
    dg.add_argument("recording", nargs="?")
    _batch_options(dg, "diagnosis", "FILE.diagnosis.json")
    dg.add_argument("--baseline", default=None,
                    help="minimal (the thesis's minimal model, fitted whole), or a damper preset or model JSON, "
                         "refitted (default: the damper the recording names, else minimal)")
    dg.add_argument("--json", action="store_true", help="machine-readable result")
    _writes(dg, "--report", FOLDER, metavar="DIR", help="HTML report with residual maps and loops")
    _overwrite(dg, "--report's files and --batch's outputs")
    dg.add_argument("--holdout", type=holdout, default="interleaved",
                    help="interleaved (default: alternate cycles or blocks) or tail:FRACTION (a time split: fit on "
                         "the first 1-2F, choose on the next F, report on the last F)")
    dg.add_argument("--next", action="store_true",
                    help="also propose the sines that would best tell apart what it could not (minimal baseline)")
    dg.add_argument("--budget", type=number(0, MAX_BUDGET_S, above=0), default=None, metavar="SECONDS",
                    help="--next: rig time the proposals may take (default 120)")
    dg.add_argument("--rig", default=None, help="--next: rig config whose limits the proposals keep (default virtual)")
    dg.set_defaults(command="diagnose")


def _analysis_commands(sub):
    """From recordings: identify, diagnose, prove the diagnosis, import CSV."""
    idf = sub.add_parser("identify", help="damper model from recordings (thesis chapter 4)")
    idf.add_argument("recordings", nargs="*", metavar="RECORDING", help="MCAP files (dyno run or dyno import)")
    idf.add_argument("--damper", default=None,
                     help="description giving layout and geometry (default: the damper the recording names)")
    _writes(idf, "--out", FILE, default=None, help="model JSON (default: RECORDING.model.json)")
    idf.add_argument("--truth", default=None, help="known damper (preset or JSON) to compare with")
    idf.add_argument("--segment", action="append", metavar="NAME", help="fit these segments only (repeatable), "
                     "e.g. one of a file's repeats at another coil current or clicker")
    idf.add_argument("--json", action="store_true", help="results as JSON on stdout")
    _writes(idf, "--report", FOLDER, default=None, metavar="DIR", help="HTML report with loops and held-out errors")
    _overwrite(idf, "--out, --report's files and --batch's outputs")
    _batch_options(idf, "identify", "FILE.model.json")
    idf.set_defaults(command="identify")
    _diagnose_command(sub)
    pv = sub.add_parser("prove", help="hide each effect in the virtual rig at the noise level and diagnose it")
    pv.add_argument("--seeds", type=number(1, 10000, integer=True), default=10,
                    help="recordings per effect (default 10)")
    pv.add_argument("--effects", help="comma-separated subset of effects, A+B for two hidden together, "
                                      "EFFECT:FORM for one of its other forms, ALL for every effect (default: all, plus nulls)")
    pv.add_argument("--forms", choices=("default", "all"), default="default",
                    help="all: each effect also in the plant's other forms (default: its calibrated form only)")
    pv.add_argument("--sizes", type=sizes, default=[1.0],
                    help="comma-separated strengths: multiples of each concealed effect (default 1), e.g. 1,3,10")
    pv.add_argument("--noise", type=sizes, default=[1.0],
                    help="comma-separated multiples of the cell's sensor noise (default 1), e.g. 1,3,10; sizes "
                         "scale with it (x1 is the noise floor at each level)")
    pv.add_argument("--rates", type=sizes, default=[1000.0],
                    help="comma-separated loop and sampling rates [Hz] (default 1000), e.g. 1000,5000")
    pv.add_argument("--open", metavar="EXPR",
                    help="hide your own physics: a force [N] in x [m], v [m/s], t [s], T [K], e.g. "
                         "'2e6*maximum(x-0.05,0)**2' (sim_backend/extra.py), against a null per seed")
    pv.add_argument("--adaptive", action="store_true",
                    help="after the prove plan, the dyno's own next tests (as dyno run discover) on the same "
                         "recording; the table gives detection by the plan alone beside it")
    pv.add_argument("--budget", type=number(0, 3600), default=120.0, metavar="SECONDS",
                    help="--adaptive: rig time the next tests may add (default 120)")
    pv.add_argument("--json", action="store_true")
    pv.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    pv.add_argument("--calibrate", action="store_true",
                    help="find each effect's concealed value (contribution = force noise) and print it")
    pv.add_argument("--jobs", type=number(1, 256, integer=True), default=2,
                    help="recordings made and diagnosed in parallel (default 2)")
    cluster_option(pv)
    pv.set_defaults(command="prove")
    ck = sub.add_parser("check", help="QA: a run against a reference run or model, within a tolerance band")
    ck.add_argument("recording")
    ck.add_argument("--against", required=True, metavar="REF.mcap|MODEL",
                    help="the reference: another run, or a damper model (preset or FILE.json) simulated along "
                         "this run's motion")
    ck.add_argument("--tolerance", default="5%",
                    help="the band, with its unit: 5%% of the reference, 50N, 11lbf, or 5%%,50N (the larger)")
    _writes(ck, "--out", FOLDER, default=None, help="folder for check.png, the band and the run's points")
    _units(ck)
    _overwrite(ck)
    ck.set_defaults(command="check")
    ex = sub.add_parser("export", help="a recording as one wide table (CSV or Parquet) on the force clock")
    ex.add_argument("recording")
    _writes(ex, "--csv", FILE, metavar="FILE", help="write CSV")
    _writes(ex, "--parquet", FILE, metavar="FILE", help="write Parquet (needs pyarrow)")
    _writes(ex, "--target", FILE, metavar="FILE", help="write a replay target: time [s] and displacement [mm] about "
                                                     "mid-stroke (dyno run replay --target FILE)")
    ex.add_argument("--segment", help="--target: only this segment (its name, e.g. 'road iso8608:C:50')")
    ex.add_argument("--channels", help="comma-separated channels (default: all, force first)")
    _units(ex)
    _overwrite(ex)
    ex.set_defaults(command="export")
    _import_command(sub)


def _import_command(sub):
    im = sub.add_parser("import", help="a recording from another dyno or a DAQ (CSV, text export, Parquet, MATLAB) "
                                       "as an MCAP recording")
    im.add_argument("file", metavar="FILE", help="CSV or any delimited text (a preamble, a decimal comma, no header: "
                                                 "found), .parquet, or .mat")
    im.add_argument("--inspect", action="store_true", help="show what would be read (layout, columns, sample values, "
                                                           "rate, a guessed map); write nothing")
    _writes(im, "--out", FILE, metavar="FILE.mcap", help="the recording to write")
    _overwrite(im, "--out")
    im.add_argument("--map", action="append", metavar="NAME=COLUMN[:UNIT]",
                    help="time, displacement, velocity, force, temperature, pressure or aux.NAME from a column by "
                         "its header or 1-based position (a MATLAB matrix's: VAR[N]); units e.g. ms, mm, mm/s, kN, C, "
                         "bar (default SI); time may be date-time stamps")
    for flag, meta, what in (("--gain", "NAME=NUMBER", "a raw channel's gain into its mapped unit, e.g. force=980.665"),
                             ("--offset", "NAME=NUMBER", "added after the gain, in the mapped unit, e.g. displacement=29.9"),
                             ("--drive", "aux.NAME=KIND", "an aux channel that drives the damper: coil current, coil "
                                                          "voltage, valve current or valve command (else a reading)")):
        im.add_argument(flag, action="append", metavar=meta, help=what)
    im.add_argument("--flip", action="append", choices=("force", "displacement"),
                    help="the file counts it the other way: force positive in tension, or displacement from the "
                         "other end (dyno: both positive in compression)")
    im.add_argument("--rate", type=number(above=0, hi=1e6), default=None, metavar="HZ",
                    help="the sampling rate, when no time column is mapped and the file does not say it")
    im.set_defaults(command="import_csv")


def main(argv=None):
    from rig import operator_stop
    try:
        with operator_stop.handled():  # from the first line: a Ctrl-C while importing is not lost
            return _main(sys.argv[1:] if argv is None else argv)
    except KeyboardInterrupt:  # before or after a command's own handling: no traceback
        return 130
    except BrokenPipeError:  # `dyno ... | head`: the reader left; nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


def _main(argv):
    if argv[:1] == ["run"] and {"-h", "--help"} & set(argv):  # a protocol's own parameters
        from protocols.app.protocols_list import protocol_help
        if any(protocol_help(a) for a in argv[1:]):
            return 0
    p = parser()
    p.check_command(argv)
    args, extra = p.parse_known_args(argv)
    if extra:  # `dyno run` takes name=value anywhere among its options
        if getattr(args, "cmd", None) == "run" and all("=" in e and not e.startswith("-") for e in extra):
            args.params += extra
        else:
            p.error(f"unrecognized arguments: {' '.join(extra)}")
    module, _, function = args.command.partition(":")
    try:
        check_outputs(p, args)
        return getattr(importlib.import_module(f"protocols.app.{module}"), function or "run")(args)
    except (DamperError, RigError, UsageError) as e:
        print(f"dyno: error: {e}", file=sys.stderr)
        return 2
    except TaskFailed as e:  # a fanned-out task failed twice (models/parallel.py)
        print(f"dyno: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
