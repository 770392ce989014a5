"""The layering and the size rules, checked on the source so they cannot silently erode.

Layers import downward only:
    protocols (the application)  ->  sim_backend  ->  rig, models
    rig and models import nothing of each other, of sim_backend or of protocols;
    inside models, the equations (physics) import nothing built on them.
No module imports another module's private names (_name). Transports are named in one
place (the registry), and so are the hidden effects."""
import ast
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("rig", "models", "sim_backend", "protocols")
FORBIDDEN = {  # importer prefix -> imported prefixes it must not use
    "rig": ("models", "sim_backend", "protocols"),
    "rig.codecs": ("rig.devices", "rig.loop", "rig.rig", "rig.safety", "rig.config"),
    "models": ("rig", "sim_backend", "protocols"),
    "models.physics": ("models.identify", "models.diagnose", "models.quarter_car", "models.validation"),
    "models.identify": ("models.diagnose", "models.quarter_car", "models.validation"),
    "models.diagnose": ("models.identify", "models.quarter_car", "models.validation"),
    "sim_backend": ("protocols",),
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
])
def test_the_layer_check_catches_what_it_should(mod, imported, names, caught):
    assert bool(violations(mod, [(imported, names)])) == caught
