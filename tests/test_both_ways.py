"""Issue 35: the Python calls refuse exactly where ./tubes exits non-zero. Each of these inputs is
run both ways: the program (an input file) must exit with the code given, and the Python call
with the same settings must raise: ValueError where the program refuses the input (exit 1),
TubesError or DisagreementError where a computation failed or a check disagreed (exit 2 or 4).
Where both take the message from one place (the program's reader, or a check of
src/workflow/tubes_verdicts.f90), it is the same text.

Before this table, m.transition returned (with a RuntimeWarning) the energies on which the program
exits 4 (past the end of the orbit family, a noisy model's transition region), and m.orbit_family
returned orbits the program refuses: integrated too coarsely (exit 2), past the family's end or
below the halo branch point (exit 4)."""
import re

import pytest
import tubes
from conftest import run_tubes

HH = "&model system = 'henon_heiles' /\n"
BALL_F = ("&model system = 'expression', hamiltonian = '(px^2 + py^2)/2 + (x^2 - 1)^2 + y^2/2', "
          "coordinates = 'x', 'y', momenta = 'px', 'py' /\n&section kind = 'plane', index = 1, value = 0.5, "
          "direction = 1 /\n")


def ball(**kw):
    return tubes.Model(**kw)


def hh():
    return tubes.Model("henon_heiles")


def double_well():
    return tubes.Model(system="expression", hamiltonian="(px^2 + py^2)/2 + (x^2 - 1)^2 + y^2/2",
                       coordinates=["x", "y"], momenta=["px", "py"])


SEC = {"kind": "plane", "index": 1, "value": 0.5, "direction": 1}

# name: (input file, exit code, the Python call, the same reader's message both ways)
CASES = {
    # the transition scene
    "transition past the family's end": (
        "&run scenes = 'transition' /\n&transition de = 100, 800 /\n", 4,
        lambda: ball().transition(dE=[100.0, 800.0]), False),
    "transition dE = 0": (
        "&run scenes = 'transition' /\n&transition de = 0 /\n", 1,
        lambda: ball().transition(dE=[0.0]), True),
    "transition dE below the energy's resolution (the ball's h0 = 1e10)": (
        "&model h0 = 1e10 /\n&run scenes = 'transition' /\n&transition de = 1 /\n", 1,
        lambda: ball(h0=1e10).transition(dE=[1.0]), True),
    "monte_carlo dE below the energy's resolution": (
        "&model h0 = 1e10 /\n&run scenes = 'montecarlo' /\n&montecarlo de = 1 /\n", 1,
        lambda: ball(h0=1e10).monte_carlo(dE=1.0), True),
    "transition dE decreasing": (
        "&run scenes = 'transition' /\n&transition de = 5, 2 /\n", 1,
        lambda: ball().transition(dE=[5.0, 2.0]), True),
    "transition area_tol < 0": (
        "&run scenes = 'transition' /\n&transition de = 5, area_tol = -1 /\n", 1,
        lambda: ball().transition(dE=[5.0], area_tol=-1.0), False),
    "transition without dE for another model": (
        HH + "&run scenes = 'transition' /\n", 1,
        lambda: hh().transition(), False),
    "transition at a saddle that does not exist": (
        HH + "&run scenes = 'transition' /\n&transition de = 0.01 /\n&orbits saddle = 'Q9' /\n", 1,
        lambda: hh().transition(dE=[0.01], saddle="Q9"), False),
    "transition with saddle_near outside the box": (
        HH + "&run scenes = 'transition' /\n&transition de = 0.01 /\n&orbits saddle_near = 50, 50 /\n", 1,
        lambda: hh().transition(dE=[0.01], saddle_near=(50, 50)), True),
    "transition of a noisy model": (
        "&model noise = 1 /\n&run scenes = 'transition' /\n&transition de = 5 /\n", 4,
        lambda: ball(noise=1.0).transition(dE=[5.0]), False),
    "transition in 3 degrees of freedom": (
        "&model system = 'cr3bp', spatial = .true. /\n&run scenes = 'transition' /\n&transition de = 0.01 /\n"
        "&section kind = 'plane', index = 1, value = 0.8, direction = 1 /\n", 1,
        lambda: tubes.Model("cr3bp", spatial=True).transition(dE=[0.01], section=SEC), False),
    "transition with an unknown integrator": (
        "&run scenes = 'transition' /\n&transition de = 5 /\n&integrator method = 'foo' /\n", 1,
        lambda: ball().transition(dE=[5.0], integrator={"method": "foo"}), True),
    "transition of a formula model without dE": (
        BALL_F + "&run scenes = 'transition' /\n", 1,
        lambda: double_well().transition(section=SEC), False),
    # the montecarlo scene
    "monte_carlo past the family's end": (
        "&run scenes = 'montecarlo' /\n&montecarlo de = 800, n_samples = 100 /\n", 4,
        lambda: ball().monte_carlo(dE=800.0, n_samples=100), False),
    "monte_carlo with t_max too short": (
        "&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = 300, t_max = 0.05 /\n", 2,
        lambda: ball().monte_carlo(dE=100.0, n_samples=300, t_max=0.05), True),
    "monte_carlo on a section the tube crosses the other way": (
        "&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = 300 /\n&section angle = 135 /\n", 2,
        lambda: ball().monte_carlo(dE=100.0, n_samples=300, section={"angle": 135}), False),
    "monte_carlo n_samples = 0": (
        "&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = 0 /\n", 1,
        lambda: ball().monte_carlo(dE=100.0, n_samples=0), True),
    "monte_carlo seed < 0": (
        "&run scenes = 'montecarlo' /\n&montecarlo de = 100, n_samples = 10, seed = -1 /\n", 1,
        lambda: ball().monte_carlo(dE=100.0, n_samples=10, seed=-1), True),
    "monte_carlo dE < 0": (
        "&run scenes = 'montecarlo' /\n&montecarlo de = -1, n_samples = 10 /\n", 1,
        lambda: ball().monte_carlo(dE=-1.0, n_samples=10), False),
    "monte_carlo without dE for another model": (
        BALL_F + "&run scenes = 'montecarlo' /\n", 1,
        lambda: double_well().monte_carlo(section=SEC), False),
    "monte_carlo in 3 degrees of freedom": (
        "&model system = 'cr3bp', spatial = .true. /\n&run scenes = 'montecarlo' /\n"
        "&montecarlo de = 0.01, n_samples = 10 /\n&section kind = 'plane', index = 1, value = 0.8, direction = 1 /\n",
        1, lambda: tubes.Model("cr3bp", spatial=True).monte_carlo(dE=0.01, n_samples=10, section=SEC), False),
    # the orbits scene
    "orbits past the family's end": (
        "&run scenes = 'orbits' /\n&orbits de = 100, 800 /\n", 4,
        lambda: ball().orbit_family(dE=[100.0, 800.0]), False),
    "orbits integrated too coarsely": (
        "&run scenes = 'orbits' /\n&orbits de = 10 /\n&integrator method = 'rk4', h = 0.05 /\n", 2,
        lambda: ball().orbit_family(dE=[10.0], integrator={"method": "rk4", "h": 0.05}), True),
    "halo orbits below the branch point": (
        "&model system = 'cr3bp', spatial = .true. /\n&run scenes = 'orbits' /\n"
        "&orbits saddle = 'L1', family = 'halo_north', de = 0.005, 0.008 /\n", 4,
        lambda: tubes.Model("cr3bp", spatial=True).orbit_family(dE=[0.005, 0.008], saddle="L1", family="halo_north"),
        False),
    # the flux scene
    "flux of a damped model": (
        "&model damping_ratio = 0.1 /\n&run scenes = 'flux' /\n&flux de = 5, n_samples = 100 /\n", 2,
        lambda: ball(damping_ratio=0.1).flux(dE=[5.0], n_samples=100), False),
    "flux dE < 0": (
        HH + "&run scenes = 'flux' /\n&flux de = -1, n_samples = 100 /\n", 1,
        lambda: hh().flux(dE=[-1.0], n_samples=100), True),
    "flux n_samples = 0": (
        HH + "&run scenes = 'flux' /\n&flux de = 0.01, n_samples = 0 /\n", 1,
        lambda: hh().flux(dE=[0.01], n_samples=0), True),
    "flux with every point undecided": (
        "&run scenes = 'flux' /\n&flux de = 10, n_samples = 500, t_max = 0.01 /\n", 2,
        lambda: ball().flux(dE=[10.0], n_samples=500, t_max=0.01), False),
}


def _program_message(stderr, code):
    """The reader's refusal without its 'FILE:LINE: ' head (exit 1), or a check's verdict (exit 2:
    the 'tubes: ' line, src/workflow/tubes_verdicts.f90)."""
    head = r"f\.nml(:\d+)?: " if code == 1 else r"tubes: "
    lines = [ln for ln in stderr.splitlines() if re.match(head, ln)]
    return re.sub(r"^f\.nml(:\d+)?: ", "", lines[0]) if lines else None


def test_the_table_has_twenty_failing_inputs():
    assert len(CASES) >= 20


@pytest.mark.parametrize("case", CASES)
def test_python_refuses_where_the_program_exits_non_zero(tmp_path, case):
    nml, code, call, same = CASES[case]
    (tmp_path / "f.nml").write_text(nml)
    r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path, timeout=300)
    assert r.returncode == code, (r.returncode, r.stderr)
    assert not (tmp_path / "f.h5").exists() or code != 1, "a refused input leaves no output"
    want = ValueError if code == 1 else (tubes.TubesError, tubes.DisagreementError)
    with pytest.raises(want) as e:
        call()
    if same:
        msg = _program_message(r.stderr, code)
        assert msg and msg in str(e.value), (msg, str(e.value))
