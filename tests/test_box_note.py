"""The equilibrium search box says what it may hide (docs/models.md, "The search box"): an
equilibrium on a face of the box (the search ends there), or a natural model without a well in
the box whose potential on the box's faces is lower than at every equilibrium found. Checked on
double wells V = (x^2 - a^2)^2 + y^2/2, whose wells are at x = +-a (closed form): the note appears
exactly when the box [-1, 1] cuts them off, and a box that holds them finds them with no note."""
import subprocess

import h5py
import numpy as np
import pytest

from conftest import TUBES


def run(tmp, a, box=None, system=None):
    model = (f"&model system = '{system}' /\n" if system else
             f"&model system = 'expression', hamiltonian = '(px^2 + py^2)/2 + (x^2 - {a}^2)^2 + y^2/2' /\n")
    eq = f"&equilibria box = {box} /\n" if box else ""
    (tmp / "b.nml").write_text("&run scenes = 'equilibria', output = 'b.h5' /\n" + model + eq)
    r = subprocess.run([str(TUBES), "b.nml"], cwd=tmp, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp / "b.h5") as f:
        g = f["equilibria"]
        return r.stderr, g.attrs.get("box_note"), np.sort(g["x"][()][g["morse_index"][()] == 0])


def test_wells_on_the_box_face_are_named(tmp_path):
    err, note, wells = run(tmp_path, 1)                      # the default box is [-1, 1]^2
    np.testing.assert_allclose(wells, [-1, 1], atol=1e-9)
    assert "note: the equilibrium W1 lies on a face of the search box (q1 = -1.00000" in err, err
    assert "widen &equilibria box" in err and note and note in err


def test_wells_outside_the_box_are_suspected(tmp_path):
    err, note, wells = run(tmp_path, 2)                      # wells at +-2, only the saddle inside
    assert wells.size == 0
    assert "no well (minimum) in the search box" in err and "V = 9.00000 at (-1.00000, 0.00000)" in err, err
    assert "lowest E = 16.0000" in err and note in err       # V(0) = a^4 = 16, V(+-1, 0) = 9


@pytest.mark.parametrize("a,box", [(1, 1.5), (2, 3)])
def test_a_box_that_holds_the_wells_finds_them_without_a_note(tmp_path, a, box):
    err, note, wells = run(tmp_path, a, box)
    np.testing.assert_allclose(wells, [-a, a], atol=1e-9)
    assert "note:" not in err and note is None, err


@pytest.mark.parametrize("system", ["rolling_ball", "henon_heiles", "de_leon_berne", "coupled_quartic", "cr3bp"])
def test_the_built_in_models_default_boxes_need_no_note(tmp_path, system):
    err, note, _ = run(tmp_path, 0, system=system)
    assert "note:" not in err and note is None, err


def test_python_warns_with_the_programs_note(tmp_path):
    import tubes
    err, note, _ = run(tmp_path, 1)
    m = tubes.Model(system="expression", hamiltonian="(px^2 + py^2)/2 + (x^2 - 1^2)^2 + y^2/2")
    with pytest.warns(RuntimeWarning) as w:
        tubes.equilibria(m)
    assert any(str(x.message) == f"equilibria: {note}" for x in w), [str(x.message) for x in w]
