"""How commands give their results: JSON, stamped Markdown for docs/results, or text."""
from __future__ import annotations

import json

from protocols.reports import markdown as md


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

