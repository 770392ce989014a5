"""The effects have one catalogue (models/diagnose/candidates.py): the plant hides the same
names (sim_backend/effects/), prove conceals each (sim_backend/plain.toml) and reads its
size from the parameter the catalogue names."""
from types import SimpleNamespace

import numpy as np
import pytest

from models.diagnose.candidates import CATALOGUE
from sim_backend.effects import HIDDEN, parse
from sim_backend.options import plain_cell

# the catalogue's candidates: the channels' alignment, fitted with every baseline, is no
# effect the plant hides (a hidden sensor delay is the larger lag that takes its place)
CANDIDATES = [n for n, e in CATALOGUE.items() if e.needs != "baseline"]


def test_the_plant_hides_exactly_the_catalogues_effects():
    assert list(HIDDEN) == CANDIDATES and all(CATALOGUE[n].supersedes in CATALOGUE for n in CATALOGUE
                                                if CATALOGUE[n].supersedes)
    assert all(name == e.name for name, e in CATALOGUE.items())


def test_prove_conceals_every_effect_in_every_form():
    from sim_backend.effects import FORMS
    _, _, prove = plain_cell()
    assert set(prove["concealed"]) == set(CANDIDATES) | set(FORMS)
    # each concealed value is one the plant takes
    for key, value in prove["concealed"].items():
        parse([f"{key}={value}"])


def test_each_effect_is_sized_by_one_of_its_own_parameters():
    t = np.linspace(0, 1, 200)
    data = SimpleNamespace(F=np.sin(2 * np.pi * t) * 1000.0, aux={"aux.valve_current": 1 + 0.3 * np.sin(t)},
                           h=np.full(len(t), t[1]))
    for name, e in CATALOGUE.items():
        eid = f"{name}:aux.valve_current" if e.needs == "aux" else name
        # a smooth basis has no one parameter that sizes it: its size is the force it adds
        assert e.estimate in [p.name for p in e.params(data, eid)] or (e.linear and e.estimate is None), name


def test_every_hidden_effect_is_accepted_at_its_guess_by_the_plants_parser():
    assert parse([f"{n}={h.guess}" for n, h in HIDDEN.items()]) == {n: h.guess for n, h in HIDDEN.items()}


def test_every_effect_acts_in_a_stated_place_and_order():
    from models.diagnose.candidates import EFFECTS, ORDER
    assert sorted(ORDER) == sorted(EFFECTS)
    assert {e.acts_on for e in EFFECTS.values()} <= {"motion", "parts", "total"}
    # the motion is shifted before anything is computed from it; the total's caps and the
    # free play's crossings come after every term of the total
    place = {"motion": 0, "parts": 1, "total": 2}
    assert [place[EFFECTS[n].acts_on] for n in ORDER] == sorted(place[EFFECTS[n].acts_on] for n in ORDER)


def test_every_effect_and_term_says_itself_and_what_it_depends_on():
    from models.diagnose.candidates import EFFECTS
    from models.diagnose.spec import NATURES, VARIABLES
    for name, e in EFFECTS.items():
        assert len(e.say) == 4 and e.say[0], name
        assert e.depends_on and set(e.depends_on) <= set(VARIABLES), name
        assert e.nature in NATURES, name


def test_an_effect_in_another_form_is_parsed_and_a_wrong_form_named():
    from sim_backend.effects import FORMS, EffectError
    assert parse(["sensor_delay:transport=1e-4", "fluid_inertia=1"]) == {
        "sensor_delay": 1e-4, "fluid_inertia": 1.0, "forms": {"sensor_delay": "transport"}}
    assert {f"{n}:{f}" for n, h in HIDDEN.items() for f in h.forms} == set(FORMS)
    with pytest.raises(EffectError, match="no form 'cubic'"):
        parse(["breakaway_friction:cubic=1.2"])


def test_the_transport_form_delays_by_its_value_between_steps():
    from collections import deque

    from sim_backend.effects.sensor_delay import transport
    past, h = deque(maxlen=10), 1e-3
    out = [transport(past, (float(k), 0.0), 2.5e-3, h)[0] for k in range(8)]
    assert out[3:] == pytest.approx([k - 2.5 for k in range(3, 8)], abs=1e-12)


def test_extra_physics_is_an_expression_in_x_v_t_T_and_nothing_else():
    from sim_backend.extra import ExtraError, compile_extra
    f = compile_extra("2e6 * maximum(x - 0.05, 0)**2 + 3 * sin(2 * pi * 50 * t) + 0 * v * T")
    assert f(0.06, 0.0, 0.0, 300.0) == pytest.approx(200.0)
    for bad in ("__import__('os')", "x.real", "open('f')", "lambda: 1", "y + 1", "'a'", "x +", "1 / (x - 0.05)", "", "  "):
        with pytest.raises(ExtraError, match="^extra:"):
            compile_extra(bad)
    assert parse(["extra:maximum(x - 0.05, 0)"]) == {"extra": "maximum(x - 0.05, 0)"}


def test_the_plant_adds_the_extra_force_on_the_load_cell():
    from proof.on_plant import offline_force
    F0, rec = offline_force({}, seed=0)
    F1, _ = offline_force({"extra": "25.0"}, seed=0)
    assert np.median((F1 - F0)[rec]) == pytest.approx(25.0, abs=0.5)


def test_no_file_outside_the_catalogue_names_an_effect():
    """An effect's physics, derivatives, words and rules live in its own module
    (models/diagnose/effects/, the open terms in terms.py); the plant's version of it in
    sim_backend/effects/NAME.py, which names no other; the search, the words, the plant,
    the commands and the benchmarks ask the effects (data files may name them: hiding.toml,
    sim_backend/plain.toml's [bench] and [prove.concealed])."""
    import re
    from pathlib import Path

    from models.diagnose.candidates import EFFECTS
    root = Path(__file__).resolve().parent.parent
    own = {root / "models/diagnose/terms.py", *(root / "models/diagnose/effects").glob("*.py")}
    said = re.compile(r"""["'](%s)["':]""" % "|".join(sorted(EFFECTS, key=len, reverse=True)))
    hits = []
    for top in ("rig", "records", "models", "sim_backend", "protocols", "views", "proof", "commands"):
        for path in sorted((root / top).rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            if path in own:
                continue
            itself = path.stem if rel.startswith("sim_backend/effects/") else None
            hits += [f"{rel}:{i}: {m.group(1)}" for i, line in enumerate(path.read_text().splitlines(), 1)
                     for m in said.finditer(line) if m.group(1) != itself]
    assert not hits, hits
