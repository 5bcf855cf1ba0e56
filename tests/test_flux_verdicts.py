"""Issue 35: tubes.flux raises exactly where ./tubes exits 2 on the flux scene's checks. Both call
the same functions (src/workflow/tubes_verdicts.f90); before, tubes.flux returned the numbers the
program refused (more than 1 % undecided points, a normal form 6 standard errors from the sampled
flux, a flux below the smallest double) without a word. Each case runs both ways: the program's
messages on stderr are the Python exception's, and check=False returns them in `verdicts`."""
import re

import pytest
import tubes
from conftest import ROOT, run_tubes

THREE_DOF = (ROOT / "input" / "three_dof.nml").read_text()
H = re.search(r"hamiltonian = '([^']*)'", THREE_DOF).group(1)
CONSTANTS = {"w2": 1.3, "w3": 2.1, "a": 0.2, "b": 0.1, "c": 0.3, "d": 0.05}
assert all(f"'{k} = {v}'" in THREE_DOF for k, v in CONSTANTS.items())


def three_dof_model():
    return tubes.Model(system="expression", hamiltonian=H, coordinates=["q1", "q2", "q3"],
                       momenta=["p1", "p2", "p3"], constants=CONSTANTS)


def three_dof_nml(flux):
    """input/three_dof.nml with the flux scene only, no section, and the given &flux."""
    text = THREE_DOF.replace("'equilibria', 'orbits', 'flux'", "'flux'")
    text = re.sub(r"&section[^/]*/", "", text)
    return re.sub(r"&flux [^/]*/", f"&flux {flux} /", text)


THREE_DOF_KW = dict(saddle_near=(0, 0, 0), equilibria={"box": 1.2, "n_grid": 5})

CASES = {
    # every point of the dividing surface still in the slab at t_max: the flux is not measured
    "undecided": ("&run scenes = 'flux' /\n&flux de = 10, 100, n_samples = 500, t_max = 0.01 /\n",
                  tubes.Model, dict(dE=[10.0, 100.0], n_samples=500, t_max=0.01)),
    # the order-2 normal form (the leading order) 6 standard errors from the sampled flux at dE = 3
    "normal form": (three_dof_nml("de = 3, order = 2, n_samples = 20000, seed = 3"), three_dof_model,
                    dict(dE=[3.0], order=2, n_samples=20000, seed=3, **THREE_DOF_KW)),
    # dE^2 below the smallest double: no number
    "too small": (three_dof_nml("de = 1e-300, 0.05, n_samples = 2000, seed = 3"), three_dof_model,
                  dict(dE=[1e-300, 0.05], n_samples=2000, seed=3, **THREE_DOF_KW)),
}


def _verdict_lines(stderr):
    return [ln for ln in stderr.splitlines() if ln.startswith("tubes: flux: dE")]


@pytest.mark.parametrize("case", CASES)
def test_python_raises_where_the_program_exits_2(tmp_path, case):
    nml, model, kw = CASES[case]
    (tmp_path / "f.nml").write_text(nml)
    r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path, timeout=600)
    assert r.returncode == 2, r.stderr
    lines = _verdict_lines(r.stderr)
    assert lines, r.stderr
    m = model()
    with pytest.raises(tubes.DisagreementError) as e:
        m.flux(**kw)
    for ln in lines:
        assert ln in str(e.value), (ln, str(e.value))
    assert e.value.partial.verdicts == lines
    t = m.flux(check=False, **kw)
    assert isinstance(t, tubes.Table) and t.verdicts == lines


def test_no_verdict_where_the_program_exits_0(tmp_path):
    """The order-2 normal form 2.3 standard errors from the sampled flux at dE = 0.5: both accept it."""
    (tmp_path / "f.nml").write_text(three_dof_nml("de = 0.5, order = 2, n_samples = 20000, seed = 3"))
    r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    t = three_dof_model().flux(dE=[0.5], order=2, n_samples=20000, seed=3, **THREE_DOF_KW)
    assert t.verdicts == []
