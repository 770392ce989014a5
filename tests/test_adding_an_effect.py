"""Adding an effect is three files (issue 93, docs/architecture.md "Adding an effect"): a
toy one, the seal's friction following the temperature, is written into a copy of the
tree as the recipe says: its candidate (models/diagnose/effects/), its physics in the
plant (sim_backend/effects/) and its concealed value (sim_backend/plain.toml). Nothing
else is touched, and the copy's registries, consistency tests and a diagnosis find it,
referee it against the same shape in time and name it."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from models.diagnose.spec import Effect

pytestmark = pytest.mark.xdist_group("toy_effect")  # one copy of the tree, on one worker
ROOT = Path(__file__).resolve().parent.parent
PRODUCT = ("workers", "rig", "records", "models", "sim_backend", "protocols", "views", "proof", "commands")

CANDIDATE = '''\
"""The seal's friction changing with temperature (its elastomer softens as it warms)."""
from __future__ import annotations

from models.diagnose.forms import fixed, temperature_gain
from models.diagnose.spec import Effect, P

_apply, _tangent = temperature_gain("Ff", "k_fT")  # the friction times 1 + k (T - T_m)

EFFECT = Effect(
    "friction_temperature", "seal friction changing with temperature",
    params=fixed(P("k_fT", 0.0, -0.05, 0.05, "1/K")), estimate="k_fT", apply=_apply, tangent=_tangent,
    acts_on="parts", needs="T", depends_on=("temperature", "velocity", "direction"), referee="friction_drift",
    order=95, listed=150,
    say=("The seal's friction changes {v} {u} per kelvin as the damper warms.", "k_fT", 100.0, "%"))
'''

PLANT = '''\
"""A seal whose friction follows the body's temperature."""
from __future__ import annotations

from sim_backend.effects.base import Hidden


class FrictionTemperature(Hidden):
    name = "friction_temperature"
    listed = 150
    unit = "1/K"
    form = "the seal's friction times 1 + VALUE (T - T_cell)"
    guess = 0.005
    hi = 0.1

    def load(self, pl, s):
        s.F += s.F_f * self.value * (pl.T - pl.T_cell)
'''

DIAGNOSIS = '''\
import json
from models.diagnose import diagnose
from models.diagnose.words import sentence
from proof.on_plant import offline_recording
from sim_backend.effects import HIDDEN
ch, ev, _ = offline_recording({"friction_temperature": 0.02}, seed=0)
r = diagnose(ch, ev)
print(json.dumps({"hidden": list(HIDDEN), "named": r.named(),
                  "steps": [{"effect": s.effect, "referee": s.referee, "stand_in": s.stand_in,
                             "words": sentence(s)} for s in r.steps]}))
'''


def _tracked():
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    return [f for f in files if f.split("/")[0] in PRODUCT] + ["pyproject.toml", "tests/test_effects.py"]


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    """A copy of the product with the toy effect added as the recipe says: (copy, touched)."""
    copy = tmp_path_factory.mktemp("with-toy-effect")
    for f in _tracked():
        (copy / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / f, copy / f)
    (copy / "models/diagnose/effects/friction_temperature.py").write_text(CANDIDATE)
    (copy / "sim_backend/effects/friction_temperature.py").write_text(PLANT)
    plain = copy / "sim_backend/plain.toml"
    plain.write_text(plain.read_text().replace("[prove.concealed]\n", "[prove.concealed]\nfriction_temperature = 0.005\n", 1))
    touched = sorted(str(p.relative_to(copy)) for p in copy.rglob("*") if p.is_file()
                     and (not (ROOT / p.relative_to(copy)).is_file()
                          or (ROOT / p.relative_to(copy)).read_bytes() != p.read_bytes()))
    return copy, touched


def _in(copy, *args):
    env = {**os.environ, "PYTHONPATH": str(copy)}
    return subprocess.run([sys.executable, *args], cwd=copy, env=env, capture_output=True, text=True, timeout=600)


def test_the_toy_effect_touches_three_files_and_passes_the_effects_own_checks(tree):
    copy, touched = tree
    assert touched == ["models/diagnose/effects/friction_temperature.py", "sim_backend/effects/friction_temperature.py",
                       "sim_backend/plain.toml"]
    # the registries, the concealed values, the words and "no file outside the catalogue
    # names an effect", run on the copy with the toy in it
    p = _in(copy, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_effects.py")
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-2000:]
    assert "passed" in p.stdout


def test_the_toy_effect_hidden_in_the_plant_is_found_refereed_in_time_and_named(tree):
    copy, _ = tree
    p = _in(copy, "-c", DIAGNOSIS)
    assert p.returncode == 0, p.stderr[-3000:]
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["hidden"][-1] == "friction_temperature"  # listed last, on both sides
    first = out["steps"][0]
    # it faced the seal's friction changing in time (a temperature that only rose could not
    # be told from it) and beat it: named, in its own words
    assert first["effect"] == "friction_temperature" and first["referee"] == "friction_drift", out
    assert first["stand_in"] is None and "friction_temperature" in out["named"], out
    assert "seal's friction changes" in first["words"], first["words"]


def test_a_typo_in_an_effects_kind_fails_where_it_is_declared():
    kw = dict(name="toy", what="a toy", params=None, estimate=None, apply=None)
    with pytest.raises(ValueError, match="effect 'toy'.*'physic' is not a valid Nature"):
        Effect(**kw, acts_on="parts", nature="physic")
    with pytest.raises(ValueError, match="effect 'toy'.*'total_' is not a valid ActsOn"):
        Effect(**kw, acts_on="total_")
    with pytest.raises(ValueError, match="effect 'toy'.*'temperatur' is not a valid Variable"):
        Effect(**kw, acts_on="parts", depends_on=("temperatur",))


def test_an_effect_following_the_temperature_without_its_referee_in_time_fails_at_import(tree):
    """Named without facing a stand-in is what a forgotten referee would do: the catalogue
    refuses it when it is built (models/diagnose/candidates.refereed)."""
    copy, _ = tree
    module = copy / "models/diagnose/effects/friction_temperature.py"
    text = module.read_text()
    try:
        for referee, why in (("", "its referee must be the same shape in time"),
                             ("loop_surface", "its referee must be the same shape in time"),
                             ("frction_drift", "its referee 'frction_drift' is no effect or term")):
            module.write_text(text.replace('referee="friction_drift"', f'referee="{referee}"'))
            p = _in(copy, "-c", "import models.diagnose.candidates")
            assert p.returncode != 0 and why in p.stderr, p.stderr[-2000:]
    finally:
        module.write_text(text)
