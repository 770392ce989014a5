"""`dyno rig zero [--rig CELL.toml] [--unloaded] [--x-mm MM]`: tare the load cell (damper
disconnected), reference the position (the true position at mid-stroke, from a gauge),
check the LVT against the LVDT's derivative; new offsets are written into the cell file
with a dated comment (the embedded virtual rig: shown, not written)."""
from __future__ import annotations

from models.damper import load as load_damper
from commands.arguments import number, units
from protocols.commissioning import QUANTITY, as_shown, looks_loaded, write_offsets
from rig.errors import RigError, UsageError
def add(sub):
    """The `dyno rig zero` command's arguments."""
    rz = sub.add_parser("zero", help="tare the load cell, reference the position, check the LVT; offsets "
                                       "written to the cell file")
    rz.add_argument("--rig", default=None, help="rig config to zero and write (default: the embedded virtual rig)")
    rz.add_argument("--damper", default="koni", help="damper preset or FILE.json: its mid-stroke is held (default koni)")
    rz.add_argument("--unloaded", action="store_true", help="the damper is disconnected: tare the load cell to zero")
    rz.add_argument("--tare-anyway", action="store_true",
                    help="tare with --unloaded even when the reading looks like the damper's gas force")
    rz.add_argument("--x-mm", type=number(), default=None, help="the true position [mm] at mid-stroke, from a gauge")
    units(rz)
    rz.set_defaults(command="rig_zero")


def run(args):
    from rig import config as rig_config
    from protocols import cell, commissioning, runner
    from protocols.plan import Plan, rig_info
    units = args.units
    F, X = (lambda si, q=q: as_shown(units, q, si) for q in ("force", "length"))
    cfg = rig_config.load(args.rig) if args.rig else rig_config.load("virtual")
    lim = cfg.limits
    if args.x_mm is not None and not lim["x_min"] <= args.x_mm / 1e3 <= lim["x_max"]:
        raise UsageError(f"--x-mm {args.x_mm:g}: the gauge's reading at mid-stroke must lie within the cell's "
                       f"stroke, {lim['x_min'] * 1e3:g} to {lim['x_max'] * 1e3:g} mm")
    damper = load_damper(args.damper)
    info = rig_info(cfg, damper)
    kept = runner.Kept()
    with cell.wired(cfg, damper) if args.rig else cell.embedded(damper, cfg) as c:
        result = runner.run_plan(Plan(commissioning, commissioning.Params()), c, [kept])
    if result.fault:
        raise RigError(f"rig zero stopped: {result.fault}")
    found = commissioning.findings(kept.arrays(), kept.events)
    changes = []
    ch = cfg.channels
    gas = looks_loaded(found["force_mean"], damper, info.x_mid)
    refused = args.unloaded and gas is not None and not args.tare_anyway
    if refused:
        print(f"force: NOT tared: it reads {F(found['force_mean'])} with the damper said to be disconnected, "
              f"and the damper's gas force at mid-stroke is {F(gas)}; disconnect it and zero again (or give "
              f"--tare-anyway if the load cell's zero is truly that far off)")
    elif args.unloaded:
        changes.append(("force", ch["force"].offset - found["force_mean"],
                        f"load cell tared with the damper disconnected: it read {F(found['force_mean'])}"))
    else:
        print(f"force: reads {F(found['force_mean'])} at rest with the damper in; not tared (give --unloaded "
              f"with the damper disconnected, so the load cell carries nothing)")
    if args.x_mm is not None:
        changes.append(("x", ch["x"].offset + args.x_mm / 1e3 - found["x_mean"],
                        f"position referenced: read {X(found['x_mean'])} where the gauge gave "
                        f"{X(args.x_mm / 1e3)}"))
    else:
        print(f"x: reads {X(found['x_mean'])} at mid-stroke ({X(info.x_mid)} planned); "
              f"not referenced (give --x-mm with the gauge's reading there)")
    g = found["lvt_gain"]
    lvt = "within" if abs(g - 1) <= commissioning.LVT_TOLERANCE else "OFF BY MORE THAN"
    print(f"v: the LVT reads {100 * (g - 1):+.2f} % against the LVDT's derivative ({lvt} "
          f"{100 * commissioning.LVT_TOLERANCE:g} %)" + ("" if lvt == "within" else
          f": check its gain, {ch['v'].gain:.6g} now, {ch['v'].gain / g:.6g} would agree"))
    for name, value, why in changes:
        q = QUANTITY[name]
        print(f"{name}: offset {as_shown(units, q, ch[name].offset)} -> {as_shown(units, q, value)} ({why})")
    path = rig_config.path_of(args.rig)
    if changes and path.resolve().parent != rig_config.CONFIG_DIR.resolve():  # never a shipped config
        print(f"written to {write_offsets(path, cfg, changes, units)}")
    elif changes:
        print("nothing written: give --rig CELL.toml, the cell's own file (the embedded virtual rig and the "
              "shipped configs are not changed)")
    return 0 if lvt == "within" and not refused else 1
