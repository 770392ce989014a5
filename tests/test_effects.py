"""The effects have one catalogue (models/diagnose/candidates.py): the plant hides the same
names (sim_backend/effects.py), prove conceals each (sim_backend/plain.toml) and reads its
size from the parameter the catalogue names."""
from types import SimpleNamespace

import numpy as np

from models.diagnose.candidates import CATALOGUE
from sim_backend.effects import EFFECTS, parse, plain_cell


def test_the_plant_hides_exactly_the_catalogues_effects():
    assert list(EFFECTS) == list(CATALOGUE)
    assert all(name == e.name for name, e in CATALOGUE.items())


def test_prove_conceals_every_effect():
    _, _, prove = plain_cell()
    assert set(prove["concealed"]) == set(CATALOGUE)


def test_each_effect_is_sized_by_one_of_its_own_parameters():
    t = np.linspace(0, 1, 200)
    data = SimpleNamespace(F=np.sin(2 * np.pi * t) * 1000.0, aux={"aux.valve_current": 1 + 0.3 * np.sin(t)})
    for name, e in CATALOGUE.items():
        eid = f"{name}:aux.valve_current" if e.needs == "aux" else name
        assert e.estimate in [p.name for p in e.params(data, eid)], name


def test_every_hidden_effect_is_accepted_at_its_guess_by_the_plants_parser():
    assert parse([f"{n}={h.guess}" for n, h in EFFECTS.items()]) == {n: h.guess for n, h in EFFECTS.items()}


def test_every_effect_acts_in_a_stated_place_and_order():
    from models.diagnose.candidates import ORDER
    assert sorted(ORDER) == sorted(CATALOGUE)
    assert {e.acts_on for e in CATALOGUE.values()} <= {"motion", "parts", "total"}
    # the motion is shifted before anything is computed from it; the total's caps and the
    # free play's crossings come after every term of the total
    place = {"motion": 0, "parts": 1, "total": 2}
    assert [place[CATALOGUE[n].acts_on] for n in ORDER] == sorted(place[CATALOGUE[n].acts_on] for n in ORDER)


def test_the_diagnosis_says_every_effect_in_words():
    from protocols.app.diagnose import SAY
    assert set(SAY) == set(CATALOGUE)
