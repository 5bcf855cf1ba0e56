"""One family, each orbit once (src/orbits/tubes_orbits.f90 orbit_family; docs/orbits.md).

An orbit is the continuation to its own energy alone, bit for bit, whatever else a call asks for:
so the orbits scene and every cut of a run share one continuation of the family and the same
orbits. Checked against single-energy calls (a second call path: no stored continuation) and
between the scenes of one run."""
import h5py
import numpy as np

import tubes
from conftest import run_tubes

KEYS = ("period", "action", "mu_unstable", "residual", "closure", "iterations")


def _alone(model, des, **kw):
    """The family at each energy by a call of its own, on a model that has kept nothing."""
    rows = []
    for d in des:
        model.forget()
        rows.append(model.orbit_family(dE=[d], **kw))
        assert model.kept()["families"] == 1
    return {k: np.array([r[k][0] for r in rows]) for k in KEYS}


def test_an_orbit_does_not_depend_on_the_other_energies_asked_for():
    m = tubes.Model()
    des = [0.1, 1, 50, 300, 760]   # below and above the first step, up to the family's end
    fam = m.orbit_family(dE=des)
    one = _alone(m, des)
    for k in KEYS:
        assert np.array_equal(np.asarray(fam[k]), one[k]), k
    # and in other units: the restricted three-body problem's L1 (energies ~1e-3; the first
    # step is scaled to the model, not 0.25 (cm/s)^2)
    cr = tubes.Model(system="cr3bp")
    kw = {"saddle_near": (0.84, 0.0), "equilibria": {"box": 1.5}}
    des = [1e-5, 1e-3, 2e-3]
    fam = cr.orbit_family(dE=des, **kw)
    one = _alone(cr, des, **kw)
    for k in KEYS:
        assert np.array_equal(np.asarray(fam[k]), one[k]), k
    assert np.all(np.asarray(fam["converged"]))


def test_the_orbits_scene_and_the_cuts_take_the_same_orbits(tmp_path):
    """A run's orbits scene, tube cuts and transition cuts at one energy: the same orbit (its
    action bit for bit), whichever scene continued the family first."""
    for scenes in ("'orbits', 'tubes', 'transition'", "'transition', 'tubes', 'orbits'"):
        (tmp_path / "s.nml").write_text(
            f"&run scenes = {scenes} /\n&orbits de = 10, 100, 300 /\n"
            "&tubes de = 100, area_tol = 1e-8 /\n&transition de = 10, 100, 300, area_tol = 1e-6 /\n")
        r = run_tubes(["s.nml", "-o", "s.h5"], tmp_path, timeout=600)
        assert r.returncode == 0, r.stderr
        with h5py.File(tmp_path / "s.h5", "r") as f:
            assert np.array_equal(f["orbits/dE"][:], f["transition/dE"][:])
            assert np.array_equal(f["orbits/action"][:], f["transition/action"][:])
            assert np.array_equal(f["orbits/action"][:], _alone(tubes.Model(), [10, 100, 300])["action"])


def test_a_model_keeps_what_its_calls_computed():
    """A Model's calls share its kept results as the program's scenes share the run's: a later
    call takes the equilibria, the family's orbits and a cut's seeds from them, with the bits of
    a call on a fresh model."""
    m = tubes.Model()
    assert m.kept() == {"equilibria": 0, "families": 0, "seeds": 0}
    fam = m.orbit_family(dE=[10, 100])
    assert m.kept() == {"equilibria": 1, "families": 1, "seeds": 0}
    cut = m.tube_cut(100)
    again = m.tube_cut(100)
    # the cut's orbit from the family; its seeds at eps and at eps / 10 (the scene's check, area_eps10)
    assert m.kept() == {"equilibria": 1, "families": 1, "seeds": 2}
    fresh = tubes.Model().tube_cut(100)
    for c in (again, fresh):
        for k in ("r", "p_r", "tau"):
            assert np.array_equal(cut[k], c[k]), k
        assert cut["area"] == c["area"] and cut["action"] == c["action"]
    assert cut["action"] == fam["action"][1]
    assert m.transition(dE=[100])["p_trans"][0] == tubes.Model().transition(dE=[100])["p_trans"][0]
    # other options are another family; a copy is the same model without the kept results
    m.orbit_family(dE=[10], tol=1e-10)
    assert m.kept()["families"] == 2
    import copy
    import pickle
    for c in (copy.copy(m), copy.deepcopy(m), pickle.loads(pickle.dumps(m))):
        assert c == m and c.kept() == {"equilibria": 0, "families": 0, "seeds": 0}
    m.forget()
    assert m.kept() == {"equilibria": 0, "families": 0, "seeds": 0}
    # a core call that makes no sense (energies not increasing: refused by the core) keeps no family
    st = tubes._settings(m, None, None, orbits={"de": [10, 300]})
    r = tubes._lib().orbit_family(*tubes._study(m, st), np.array([300.0, 10.0]), 1, 1, 1e-11, 1e-13, 1e-13,
                                  25, 201, *tubes._integ(st, m), m._stores(), 0, np.zeros(6), 0.0)   # no guess
    assert r[0] < 0 and m.kept()["families"] == 0
