"""The layering and the size rules, checked on the source so they cannot silently erode.

Layers import downward only:
    commands -> proof -> views -> protocols -> sim_backend -> models -> records -> rig -> workers
    (the command line; prove and the benchmarks; finished recordings read for people (reports,
    the web view, the run index, exports); a run's life (plans, runner, cell); the virtual
    cell; the physics; a run as data and its files; the cell's drivers and loop; work
    spread over the cores). workers imports none of the others, rig only workers, records
    only rig, models only records and workers (never rig itself); inside models, the
    damper's description imports no equation, the equations (physics) nothing built on them.
No module imports another module's private names (_name), no modules import each other in a
circle, no command imports another command. Transports are named in one place (the
registry), and so are the hidden effects."""
import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# the rooms, bottom to top: each imports only those below it
PACKAGES = ("workers", "rig", "records", "models", "sim_backend", "protocols", "views", "proof", "commands")
ABOVE = {room: PACKAGES[i + 1:] for i, room in enumerate(PACKAGES)}
FORBIDDEN = {  # importer prefix -> imported prefixes it must not use
    **ABOVE,
    "rig.codecs": ("rig.devices", "rig.loop", "rig.rig", "rig.safety", "rig.config"),
    "models": ("rig", *ABOVE["models"]),  # a model is the same on any cell and on a file
    # the damper's description is what the equations take: it imports none of them
    "models.damper": ("models.physics", "models.identify", "models.diagnose", "models.quarter_car",
                      "models.validation"),
    "models.physics": ("models.identify", "models.diagnose", "models.quarter_car", "models.validation"),
    "models.identify": ("models.diagnose", "models.quarter_car", "models.validation"),
    "models.diagnose": ("models.identify", "models.quarter_car", "models.validation"),
    "sim_backend": (*ABOVE["sim_backend"], "models.diagnose"),  # the plant hides physics it knows itself
    # the reading room reads what a run wrote: it may name a protocol's units or constants,
    # never the machinery that runs one
    "views": (*ABOVE["views"], "protocols.runner", "protocols.cell", "protocols.live", "protocols.live_diagnose",
              "protocols.live_identify", "protocols.preflight", "protocols.discover", "protocols.commissioning",
              "protocols.rehearsal", "protocols.recorded", "protocols.segment_feed", "protocols.cluster"),
}
MAX_FILE_LINES = 450
MAX_FUNCTION_LINES = 80


def sources():
    files = subprocess.run(["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True).stdout.split()
    return [ROOT / f for f in files if f.split("/")[0] in PACKAGES]


def module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts), parts[-1] == "__init__"


def imports(path):
    """[(imported module, [names])] of a source file, relative imports resolved."""
    mod, is_pkg = module_name(path)
    package = mod if is_pkg else mod.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1] + ([base] if base else []))
            out.append((base, [a.name for a in node.names]))
    return out


def within(name, prefix):
    return name == prefix or name.startswith(prefix + ".")


def violations(mod, imported_list):
    """What module `mod` imports against the layers, from its [(module, [names])]."""
    bad = []
    for imported, names in imported_list:
        targets = [imported] + [f"{imported}.{n}" for n in names]
        for importer, forbidden in FORBIDDEN.items():
            if within(mod, importer):
                bad += [f"{mod} imports {t}" for t in targets for f in forbidden if within(t, f)]
    return sorted(set(bad))


def test_layers_import_downward_only():
    bad = []
    for path in sources():
        bad += violations(module_name(path)[0], imports(path))
    assert not bad


def test_no_module_imports_another_modules_private_names():
    bad = []
    for path in sources():
        mod, _ = module_name(path)
        for imported, names in imports(path):
            if imported.split(".")[0] in PACKAGES and imported != mod:
                bad += [f"{mod}: from {imported} import {n}" for n in names if n.startswith("_")]
    assert not bad


def graph():
    """{module: project modules it imports}; `from package import submodule` is an edge to
    the submodule alone."""
    mods = {module_name(p)[0]: p for p in sources()}
    out = {}
    for mod, path in mods.items():
        edges = set()
        for imported, names in imports(path):
            subs = [f"{imported}.{n}" for n in names if f"{imported}.{n}" in mods]
            edges.update(t for t in (subs if names and len(subs) == len(names) else [imported, *subs])
                         if t in mods and t != mod)
        out[mod] = edges
    return out


def _reached(g, start):
    reach, todo = set(), [start]
    while todo:
        for t in g[todo.pop()] - reach:
            reach.add(t)
            todo.append(t)
    return reach


def circles(g):
    """The sets of modules that import each other, directly or round about."""
    reach = {m: _reached(g, m) for m in g}
    return sorted({tuple(sorted({m} | {n for n in reach[m] if m in reach[n]})) for m in g if m in reach[m]})


def test_no_modules_import_each_other_in_a_circle():
    assert not circles(graph())


def _command_modules():
    """The modules of commands that are commands (the benches': commands.bench)."""
    from commands.cli import COMMANDS
    names = [m for c in COMMANDS for m in (c[2] if isinstance(c, tuple) else [c])]
    return {f"commands.{n}" for n in names if not n.startswith("bench")} | {"commands.bench"}


def _file(module):
    path = ROOT / module.replace(".", "/")
    return path / "__init__.py" if path.is_dir() else path.with_suffix(".py")


def test_no_command_imports_another_command():
    """A command parses, calls the library and prints: what two commands share lives below them."""
    commands = _command_modules()
    assert len(commands) > 15
    g = graph()
    assert not sorted(f"{c} imports {t}" for c in commands for t in g[c] & commands)


HEAVY = ("scipy", "numba", "matplotlib", "mcap", "rerun", "flask", "werkzeug", "jinja2", "can", "serial", "pymodbus",
         "models.diagnose", "models.identify", "sim_backend", "protocols.runner", "views.reports.recording")


def test_each_command_declares_its_arguments_and_building_the_parser_stays_light():
    """Every command module declares its own arguments (add) beside its run, and imports what
    it runs only when it runs: building `dyno`'s parser (every call, --help included) loads
    none of the analysis, the rig's transports or the plots."""
    code = ("import sys; from commands.cli import parser; parser(); "
            f"print(sorted(m for m in sys.modules if m.startswith({HEAVY!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True).stdout
    assert out.strip() == "[]", out
    cli = (ROOT / "commands/cli.py").read_text()
    assert "set_defaults(command" not in cli  # no command declared in the table itself
    for m in _command_modules() - {"commands.bench"}:  # the benches declare theirs in bench/arguments.py
        assert "def add(sub)" in _file(m).read_text(), m


MAX_COMMAND_LINES = 150  # lines a command module stays under


def test_nothing_below_the_command_layer_imports_it():
    """The commands call the library, never the other way: a bench, a proof or a run's life
    reaches an import or a model through the library, not through `dyno`'s parser."""
    bad = [f"{m} imports {t}" for path in sources() if not within(m := module_name(path)[0], "commands")
           for t, _ in imports(path) if within(t, "commands")]
    assert not bad


def test_every_command_only_parses_calls_and_prints():
    """A command module is short: its work (a run's life, an import, a proof's matrix, a
    model's documents) lives below the command layer, where other callers reach it too."""
    long = {m: n for m in _command_modules() if (n := len(_file(m).read_text().splitlines())) >= MAX_COMMAND_LINES}
    assert not long, long


def test_no_application_code_opens_a_simulator_file():
    """A real cell reads only its own files: no path in rig/, records/, models/, protocols/,
    views/ or commands/ names a file of sim_backend/ (the simulator opens its own, in its functions;
    proof/ is the simulator's harness). Sentences may name one."""
    own = {p.name for p in (ROOT / "sim_backend").rglob("*.toml")}
    bad = []
    for path in sources():
        if path.relative_to(ROOT).parts[0] in ("rig", "records", "models", "protocols", "views", "commands"):
            for n in ast.walk(ast.parse(path.read_text())):
                path_like = isinstance(n, ast.Constant) and isinstance(n.value, str) and not re.search(r"\s", n.value)
                if (path_like and (n.value.rpartition("/")[2] in own or "sim_backend/" in n.value)
                        or isinstance(n, ast.Attribute) and n.attr == "__file__" and "sim_backend" in ast.unparse(n)):
                    bad.append(f"{path.relative_to(ROOT)}:{n.lineno}")
    assert not bad


# an event's kind and message are its class and field (records/events.py); only the wire
# (the events' own module, the MCAP reader) and the inference of an old segment's kind
# (records/data.py) read them as keys
EVENT_KEYS = ("kind", "message")
EVENT_WIRE = ("records/events.py", "records/data.py", "records/reader.py")


def keyed_reads(tree, keys):
    """Lines where a literal key of `keys` is read: x["kind"] or x.get("kind")."""
    out = []
    for n in ast.walk(tree):
        key = (n.slice if isinstance(n, ast.Subscript) and isinstance(n.ctx, ast.Load) else
               n.args[0] if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr == "get"
               and n.args else None)
        if isinstance(key, ast.Constant) and key.value in keys:
            out.append(n.lineno)
    return out


def test_no_reader_of_an_event_uses_a_string_key():
    bad = [f"{p.relative_to(ROOT)}:{line}" for p in sources() if str(p.relative_to(ROOT)) not in EVENT_WIRE
           for line in keyed_reads(ast.parse(p.read_text()), EVENT_KEYS)]
    assert not bad
    assert keyed_reads(ast.parse('a = e["kind"]\nb = e.get("message", "")\ne["kind"] = 1'), EVENT_KEYS) == [1, 2]


def test_only_the_run_index_speaks_sql():
    """The run index owns its schema: every reader (the CLI, the web view) goes through
    views/run_index.py."""
    bad = [f"{p.relative_to(ROOT)}" for p in sources() if p.relative_to(ROOT).as_posix() != "views/run_index.py"
           and re.search(r"\b(SELECT|INSERT INTO|UPDATE \w+ SET|DELETE FROM)\b", p.read_text())]
    assert not bad


def test_the_circle_check_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [("a", "b", "c")]
    assert not circles({"a": {"b"}, "b": set()})


def test_files_and_functions_stay_small():
    """No file over 450 lines, no function over 80 (compiled numerical kernels excepted)."""
    bad = []
    for path in sources():
        text = path.read_text()
        if text.count("\n") > MAX_FILE_LINES:
            bad.append(f"{path.relative_to(ROOT)}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                compiled = any("njit" in ast.unparse(d) for d in node.decorator_list)
                if n > MAX_FUNCTION_LINES and not compiled:
                    bad.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {n} lines")
    assert not bad


def test_transports_are_named_only_in_their_registry():
    hits = []
    for path in sources():
        for i, line in enumerate(path.read_text().splitlines(), 1):
            if "transport ==" in line or "transport !=" in line:
                hits.append(f"{path.relative_to(ROOT)}:{i}")
    assert all(h.startswith("rig/devices/__init__.py:") for h in hits), hits


@pytest.mark.parametrize("mod, imported, names, caught", [
    ("rig.loop", "protocols.runner", ["Observers"], True),
    ("rig.devices.can", "rig", ["config"], False),
    ("models.physics.kernel", "models.identify", ["static"], True),
    ("models.physics.kernel", "models", ["identify"], True),
    ("sim_backend.plant", "models.physics.simulate", ["Stepper"], False),
    ("rig.codecs.can", "rig.devices", ["TRANSPORTS"], True),
    ("views.reports.hil", "protocols.library.replay", ["RECOVER_S"], False),
    ("views.export", "protocols.runner", ["run_plan"], True),
    ("protocols.runner", "views.reports", ["plots"], True),
])
def test_the_layer_check_catches_what_it_should(mod, imported, names, caught):
    assert bool(violations(mod, [(imported, names)])) == caught


def public_classes():
    """{class name: [module]} of the public classes the product modules define at top level."""
    out = {}
    for path in sources():
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                out.setdefault(node.name, []).append(module_name(path)[0])
    return out


def test_one_name_per_concept():
    """No two product modules define a public class of one name: a reader meeting `Result`
    or `Segment` knows which thing it is. Each protocol's `Params` is one convention."""
    twice = {name: mods for name, mods in public_classes().items() if len(mods) > 1 and name != "Params"}
    assert not twice, twice
    assert len(public_classes()) > 100  # the check sees the tree


def test_every_stamped_table_has_the_make_line_that_writes_it():
    """A stamped table is true of the code that made it only if it can be made again: each
    docs/results table is written by a line of `make results` or `make results-long`, but
    bench-loop-live.md, four bench runs assembled with their prose (the Makefile says so)."""
    make = (ROOT / "Makefile").read_text()
    written = set(re.findall(r"> docs/results/([\w-]+\.md)\.tmp", make))
    tables = {p.name for p in (ROOT / "docs" / "results").glob("*.md")}
    assert tables - written == {"bench-loop-live.md"}, sorted(tables - written)
    assert written <= tables, sorted(written - tables)
    assert "bench-loop-live.md is four" in make
