"""The `dyno` command line: the commands' table and their errors. Each command is a module
of commands that declares its arguments (add) and runs them (run). Errors in what the user gave us are one line and exit 2."""
from __future__ import annotations

import importlib
import os
import sys
from importlib import metadata

from models.damper import DamperError
from workers.pool import TaskFailed
from commands.arguments import Parser, negative_values
from commands.output import check_outputs
from rig.errors import Refused, UsageError
from rig.errors import RigError


# the commands in the order `dyno` lists them; each module of commands declares its
# own arguments beside it (its add(sub)) and imports what it runs only when it runs
COMMANDS = ("validate", "plot", "sim_rig", "protocols_list", "run", "recover", "report",
            ("rig", "the test cell", ("rig_check", "rig_zero")), "runs", "serve", "identify", "diagnose", "prove",
            "check", "export", "import_csv", "bench.arguments")


def parser():
    p = Parser(prog="dyno", description="Damper dyno controller and damper model tools")
    p.add_argument("--version", action="version", version=f"dyno {metadata.version('dyno')}")
    sub = p.add_subparsers(dest="cmd", required=True)
    for c in COMMANDS:
        if isinstance(c, tuple):  # a group: `dyno rig check`, `dyno rig zero`
            name, helptext, members = c
            group = sub.add_parser(name, help=helptext).add_subparsers(dest="what", required=True)
            for m in members:
                importlib.import_module(f"commands.{m}").add(group)
        else:
            importlib.import_module(f"commands.{c}").add(sub)
    p.commands = sub.choices  # {name: its parser}: what a mistyped command is matched against (check_command)
    return p


STOPPED = "dyno: stopped by the operator; nothing half-written was left"


def main(argv=None):
    from rig import operator_stop
    try:
        with operator_stop.handled():  # from the first line: a Ctrl-C while importing is not lost
            return _main(sys.argv[1:] if argv is None else argv)
    except KeyboardInterrupt:  # before or after a command's own handling: no traceback
        print(STOPPED, file=sys.stderr)
        return 130
    except BrokenPipeError:  # `dyno ... | head`: the reader left; nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


def _main(argv):
    if argv[:1] == ["run"] and {"-h", "--help"} & set(argv):  # a protocol's own parameters
        from commands.protocols_list import protocol_help
        if any(protocol_help(a) for a in argv[1:]):
            return 0
    p = parser()
    p.check_command(argv)
    argv = negative_values(p, argv)
    args, extra = p.parse_known_args(argv)
    if extra:  # `dyno run` takes name=value anywhere among its options
        if getattr(args, "cmd", None) == "run" and all("=" in e and not e.startswith("-") for e in extra):
            args.params += extra
        else:
            p.error(f"unrecognized arguments: {' '.join(extra)}")
    module, _, function = args.command.partition(":")
    try:
        check_outputs(p, args)
        return getattr(importlib.import_module(f"commands.{module}"), function or "run")(args)
    except (DamperError, RigError, UsageError) as e:
        print(f"dyno: error: {e}", file=sys.stderr)
        return 2
    except (TaskFailed, Refused) as e:  # a fanned-out task failed twice (workers/pool.py); a poor model
        print(f"dyno: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # a run says its own stop; any other command's output is written whole or not at all
        print(STOPPED, file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
