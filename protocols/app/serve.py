"""`dyno serve [DIR] [--port 8050]`: the browser view of a folder's runs (protocols/web),
on 127.0.0.1 only, until Ctrl-C."""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from werkzeug.serving import make_server

from protocols import catalogue
from protocols.units import Units
from protocols.web import create_app
from rig.errors import RigError


def run(args):
    folder = Path(args.dir)
    if not folder.is_dir():
        raise RigError(f"{folder}: no such folder of recordings")
    n = catalogue.index(folder)
    cache = tempfile.mkdtemp(prefix="dyno-serve-")
    try:
        server = make_server("127.0.0.1", args.port, create_app(folder, Units(args.units), cache), threaded=True)
    except OSError as e:
        shutil.rmtree(cache, ignore_errors=True)
        raise RigError(f"--port {args.port}: cannot listen on 127.0.0.1 ({e.strerror})") from None
    print(f"{folder}: {n.added + n.updated + n.unchanged + n.failed} recordings ({n.failed} unreadable); "
          f"serving http://127.0.0.1:{server.server_port}/ (Ctrl-C stops)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
        shutil.rmtree(cache, ignore_errors=True)
    return 0
