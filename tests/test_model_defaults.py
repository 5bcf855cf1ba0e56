"""The scenes' default excess energies and the trajectory's default start are the four-well ball's
(the paper's, in (cm/s)^2 and cm): any other model must give its own, on the command line as in
Python (tubes._default_de). Before, a formula model ran the ball's 15 energies 1 .. 750 (NaN rows,
exit 4) and Hénon–Heiles' trajectory started at the ball's (4, 12.6) cm and blew up (exit 2)."""
import pytest

from conftest import run_tubes

FORMULA = "&model system = 'expression', hamiltonian = '(px^2 + py^2)/2 + (x^2 - 1)^2 + y^2/2' /\n" \
          "&equilibria box = 2 /\n&section kind = 'plane', index = 1, value = -0.5, direction = 1 /\n"


@pytest.mark.parametrize("scene", ["orbits", "tubes", "transition", "montecarlo", "sections", "flux"])
@pytest.mark.parametrize("model", ["formula", "henon_heiles", "ball_on_a_formula"])
def test_a_scene_without_de_is_refused_for_any_model_but_the_ball(tmp_path, scene, model):
    text = {"formula": FORMULA, "henon_heiles": "&model system = 'henon_heiles' /\n",
            "ball_on_a_formula": "&model surface = 'expression', height = '0.07*(x^2 + y^2) - "
                                 "1.017*(sqrt(x^2 + 15.1) + sqrt(y^2 + 15.1))' /\n"
                                 "&section kind = 'plane', index = 1, value = 3, direction = 1 /\n"}[model]
    (tmp_path / "m.nml").write_text(f"&run scenes = '{scene}', output = 'm.h5' /\n" + text)
    for args in (["--check", "m.nml"], ["m.nml"]):
        r = run_tubes(args, tmp_path)
        assert r.returncode == 1, (args, r.stderr)
        assert f"m.nml:1: &{scene}: de is not set: system" in r.stderr, r.stderr
        assert "four-well ball's, in (cm/s)^2" in r.stderr
    assert not list(tmp_path.glob("m.h5*"))


def test_the_flux_takes_the_transition_list_when_given(tmp_path):
    (tmp_path / "m.nml").write_text("&run scenes = 'flux', output = 'm.h5' /\n" + FORMULA
                                    + "&transition de = 0.05 /\n&flux n_samples = 2000 /\n")
    r = run_tubes(["--check", "m.nml"], tmp_path)
    assert r.returncode == 0, r.stderr


def test_a_trajectory_of_another_model_needs_its_start(tmp_path):
    (tmp_path / "t.nml").write_text("&run scenes = 'trajectory', output = 't.h5' /\n&model system = 'henon_heiles' /\n")
    r = run_tubes(["t.nml"], tmp_path)
    assert r.returncode == 1 and "&trajectory: x0 or y0 is not set: system henon_heiles has no default start" in r.stderr
    # one of them alone: refused too (it ran from the ball's y0 = 12.6 before: Henon-Heiles escapes)
    (tmp_path / "t.nml").write_text("&run scenes = 'trajectory', output = 't.h5' /\n&model system = 'henon_heiles' /\n"
                                    "&trajectory x0 = 0.1, t_end = 10 /\n")
    r = run_tubes(["t.nml"], tmp_path)
    assert r.returncode == 1 and "x0 or y0 is not set: system henon_heiles" in r.stderr
    assert not list(tmp_path.glob("t.h5*"))
    (tmp_path / "t.nml").write_text("&run scenes = 'trajectory', output = 't.h5' /\n&model system = 'henon_heiles' /\n"
                                    "&trajectory x0 = 0.1, y0 = 0.1, t_end = 10 /\n")
    r = run_tubes(["t.nml"], tmp_path)
    assert r.returncode == 0, r.stderr


def test_the_ball_keeps_its_defaults(tmp_path):
    (tmp_path / "b.nml").write_text("&run scenes = 'transition', 'trajectory', output = 'b.h5' /\n"
                                    "&transition de = 10 /\n&model xi = 0 /\n")
    r = run_tubes(["--check", "b.nml"], tmp_path)
    assert r.returncode == 0, r.stderr
