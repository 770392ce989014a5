"""`dyno serve [DIR] [--port 8050]`: the browser view of a folder's runs (views/web),
on 127.0.0.1 only, until Ctrl-C."""
from __future__ import annotations

import shutil
import socket
import sys
import tempfile
from contextlib import closing
from pathlib import Path

from rig.errors import UsageError
from commands.arguments import number, units


def add(sub):
    """The `dyno serve` command's arguments."""
    sv = sub.add_parser("serve", help="the runs in a browser: table, reports, comparisons, trends, QA, live runs")
    sv.add_argument("dir", nargs="?", default="recordings")
    sv.add_argument("--port", type=number(0, 65535, integer=True), default=8050,
                    help="port on 127.0.0.1 (default 8050; 0 picks a free one)")
    units(sv)
    sv.set_defaults(command="serve")


def _free(port):
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server will
        try:
            s.bind(("127.0.0.1", port))
        except OSError as e:
            raise UsageError(f"--port {port}: cannot listen on 127.0.0.1 ({e.strerror}); give another --port") from None


def run(args):
    from werkzeug.serving import make_server
    from views import run_index
    from views.web import create_app
    folder = Path(args.dir)
    if not folder.is_dir():
        raise UsageError(f"{folder}: no such folder of recordings")
    _free(args.port)  # werkzeug would print its own two lines and exit
    try:
        run_index.index(folder)
    except run_index.RunIndexError as e:
        print(f"dyno: {e}; serving what can be read", file=sys.stderr)
    try:
        with closing(run_index.connect(folder, write=False)) as c:
            total, unreadable = run_index.counts(c)
        found = f"{total} recordings ({unreadable} unreadable)"
    except run_index.RunIndexError:
        found = "no readable run index (live runs only)"
    cache = tempfile.mkdtemp(prefix="dyno-serve-")
    server = make_server("127.0.0.1", args.port, create_app(folder, args.units, cache), threaded=True)
    print(f"{folder}: {found}; "
          f"serving http://127.0.0.1:{server.server_port}/ (Ctrl-C stops)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
        shutil.rmtree(cache, ignore_errors=True)
    return 0
