"""How commands give their results: JSON, stamped Markdown for docs/results, or text."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from views.reports import markdown as md
from rig.errors import UsageError


def emit(args, title, result, text, body=None, note=""):
    """A command's result: JSON (--json), a stamped Markdown page for docs/results
    (--markdown; body defaults to a table of the result's values) or text lines."""
    if getattr(args, "json", False):
        print(json.dumps(result, indent=2))
    elif getattr(args, "markdown", False):
        print(md.document(title, body if body is not None else md.table(("quantity", "value"), md.flat(result)), note))
    else:
        print(text)
    return 0


def chosen(p, args):
    """The parsers `args` went through: dyno's, then each subcommand's."""
    out = [p]
    while True:
        subs = [a for a in out[-1]._actions if isinstance(a, argparse._SubParsersAction)]
        name = getattr(args, subs[0].dest, None) if subs else None
        if name is None:
            return out
        out.append(subs[0].choices[name])


def check_outputs(p, args):
    """Every file or folder the command will write, checked by the one rule before it
    starts: never an input (any file named among its other arguments), kept unless
    --overwrite, each a path of its own. A positional argument given as "" is named (a
    shell variable left empty), never read as the folder it resolves to."""
    from records.files import existing_files, output_file, output_folder
    actions = [a for q in chosen(p, args) for a in q._actions if a.dest != "help"]
    for a in (a for a in actions if not a.option_strings):
        value = getattr(args, a.dest, None)
        if value == "" or isinstance(value, list) and "" in value:
            raise UsageError(f"{a.metavar or a.dest}: an empty name (\"\") given: a file's name was expected "
                             f"(a shell variable left empty?)")
    outputs = [(a, getattr(args, a.dest, None)) for a in actions if getattr(a, "writes", None)]
    outputs = [(a, v) for a, v in outputs if v is not None]
    inputs = existing_files(*(getattr(args, a.dest, None) for a in actions if not getattr(a, "writes", None)))
    seen = {}
    for a, value in outputs:
        flag = a.option_strings[0]
        where = Path(value).resolve()
        if where in seen:
            raise UsageError(f"{flag} {value}: also given to {seen[where]}; each output needs a path of its own")
        seen[where] = flag
        check = output_file if a.writes == "file" else output_folder
        check(value, inputs, getattr(args, "overwrite", False), flag)
