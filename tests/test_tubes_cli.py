"""Tube dynamics scenes through the executable: A_E against an estimate that uses only the
energy function, p_trans's leading order, the Monte Carlo check, identical output for 1 and 2
threads, and the Poincare maps."""
import os
import re
import subprocess

import h5py
import numpy as np
import pytest

import tubes
from conftest import TUBES, run_tubes


def tubes_path():
    return str(TUBES)

NML = ("&run scenes = 'tubes', 'transition', 'montecarlo', 'sections' /\n"
       "&tubes de = 100 /\n&transition de = 2, 100 /\n&montecarlo n_samples = 2000 /\n"
       "&sections de = 100, n_seeds = 6, n_iter = 20 /\n")


def _run(tmp_path, nthreads, name):
    (tmp_path / "t.nml").write_text(NML)
    env = dict(os.environ, OMP_NUM_THREADS=str(nthreads))
    r = subprocess.run([tubes_path(), "t.nml", "-o", name],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return r


def test_scenes_and_independent_checks(tmp_path, tubes_exe):
    r = _run(tmp_path, 2, "a.h5")
    with h5py.File(tmp_path / "a.h5") as f:
        sec = f["section"].attrs
        # A_E at dE = 100 by sampling: (r, p_r) is in the region iff min over p_theta of the
        # energy (a parabola in p_theta: three evaluations give it exactly) is <= E
        tr = f["transition"]
        k = list(tr["dE"][:]).index(100.0)
        a_e = tr["A_E"][k]
        cut = f["tubes/stable_000"]
        e = tubes.energy(cut["state"][0])          # the cut's points lie on the energy surface
        rng = np.random.default_rng(3)
        n = 20000
        rs = rng.uniform(sec["r_min"] - 0.5, sec["r_max"] + 0.5, n)
        prs = rng.uniform(-70.0, 70.0, n)
        c = np.sqrt(0.5)
        inside = 0
        for rr, pp in zip(rs, prs):
            def en(pt):
                return tubes.energy([rr * c, rr * c, c * pp - c * pt / rr, c * pp + c * pt / rr])
            e0, ep, em = en(0.0), en(1.0), en(-1.0)
            a2 = (ep + em - 2 * e0) / 2
            b = (ep - em) / 2
            inside += (e0 - b * b / (4 * a2)) <= e
        box = (sec["r_max"] - sec["r_min"] + 1.0) * 140.0
        est = box * inside / n
        se = box * np.sqrt(inside / n * (1 - inside / n) / n)
        assert abs(est - a_e) < 4 * se, (est, a_e, se)
        # the tube cut's area equals the orbit's action; eps/10 changes it negligibly
        assert abs(cut.attrs["area"] / cut.attrs["action"] - 1) < 1e-8
        assert cut.attrs["area_eps_change"] < 1e-8 * cut.attrs["area"]
        # p_trans -> the leading-order formula as dE -> 0 (at dE = 2 the O(dE^2) term is ~1e-3 of it)
        p, pl = tr["p_trans"][0], tr["p_trans_leading"][0]
        assert abs(p / pl - 1) < 1e-3
        assert abs(sec["growth_rate"] - sec["T_po"] / sec["A0"]) < 1e-15
        mc = f["montecarlo"].attrs
        assert abs(mc["fraction"] - mc["p_trans"]) < 4 * mc["std_error"]
        assert mc["misclassified"] == 0
        pts = f["sections/map_000/points"][:]
        assert pts.shape == (6, 20, 2) and np.isfinite(pts).all()
        assert np.all(pts[:, :, 0] > sec["r_min"] - 1)   # returns lie on the section's region


def test_identical_for_1_and_2_threads(tmp_path, tubes_exe):
    _run(tmp_path, 1, "one.h5")
    _run(tmp_path, 2, "two.h5")
    with h5py.File(tmp_path / "one.h5") as f1, h5py.File(tmp_path / "two.h5") as f2:
        for d in ["tubes/stable_000/r", "tubes/stable_000/p_r", "transition/A_tube", "transition/p_trans",
                  "montecarlo/transit", "montecarlo/r", "sections/map_000/points"]:
            assert np.array_equal(f1[d][:], f2[d][:], equal_nan=True), d
        assert f1["montecarlo"].attrs["fraction"] == f2["montecarlo"].attrs["fraction"]


def test_tube_plots(tmp_path, tubes_exe):
    _run(tmp_path, 2, "p.h5")
    from tubes import plots
    assert plots.main([str(tmp_path / "p.h5"), "-o", str(tmp_path / "fig")]) == 0
    for name in ["section_dE100.png", "p_trans.png", "tube_trajectories.png"]:
        assert (tmp_path / "fig" / name).stat().st_size > 10_000, name


def test_past_the_end_of_the_family_is_said_once_per_scene_and_recorded(tmp_path):
    """The S12 family ends near dE = 777 (the orbits scene's estimate, docs/orbits.md): a tube,
    p_trans or Monte Carlo check asked at dE = 800 is refused with the orbits scene's words, once
    per scene, exit 4 (partial), and the file records the status (TUBES_EPASTEND = -10)."""
    (tmp_path / "p.nml").write_text("&run scenes = 'orbits', 'tubes', 'transition', 'montecarlo' /\n"
                                    "&orbits dE = 100, 800 /\n&tubes dE = 800 /\n"
                                    "&transition dE = 100, 800 /\n&montecarlo dE = 800 /\n")
    r = run_tubes(["p.nml", "-o", "p.h5"], tmp_path)
    assert r.returncode == 4, r.stderr
    end = [ln for ln in r.stdout.splitlines() if "family end: dE ~" in ln][0]
    end_de = float(end.split("dE ~")[1].split()[0])
    assert 700 < end_de < 800
    # tubes, transition, montecarlo (the end is an extrapolation: its digits depend on the path)
    ends = re.findall(r"tubes: dE = 800 is past the end of the S12 family, which ends at dE ~ ([0-9.]+)", r.stderr)
    assert len(ends) == 3, r.stderr
    assert all(abs(float(x) / end_de - 1) < 1e-5 for x in ends), (ends, end_de)
    assert "did not converge" not in r.stderr and "tubes: tubes:" not in r.stderr
    assert r.stdout.count("refused: past the end of the family") == 3   # orbits, tubes, transition
    with h5py.File(tmp_path / "p.h5") as f:
        assert f.attrs["exit_status"] == 4
        assert list(f["transition/status"][:]) == [0, tubes.EPASTEND]
        assert f["transition/p_trans"][0] > 0 and np.isnan(f["transition/p_trans"][1])
        assert f["montecarlo"].attrs["status"] == tubes.EPASTEND and f["montecarlo"].attrs["agrees"] == 0
        assert "past the end" in f["montecarlo"].attrs["status_message"]


def test_a_numerical_failure_of_the_monte_carlo_check_is_recorded_in_the_file(tmp_path):
    """exit 2 with the failure in the file (docs/usage.md): an injected failure of sample 3."""
    (tmp_path / "m.nml").write_text("&run scenes = 'transition', 'montecarlo' /\n&transition dE = 100 /\n"
                                    "&montecarlo n_samples = 500 /\n")
    env = dict(os.environ, OMP_NUM_THREADS="1", TUBES_FAULT="sample:3")
    r = subprocess.run([tubes_path(), "m.nml", "-o", "m.h5"], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    assert "sample 3 at (r, p_r)" in r.stderr
    with h5py.File(tmp_path / "m.h5") as f:
        assert f.attrs["exit_status"] == 2
        g = f["montecarlo"]
        assert g.attrs["status"] == tubes.EFAULT and g.attrs["agrees"] == 0
        assert g["transit"][2] == tubes.EFAULT and "fraction" not in g.attrs
        assert list(f["transition/status"][:]) == [0]


def test_the_monte_carlo_check_counts_standard_errors_of_the_tubes_p(tmp_path):
    """A handful of points without a transit is no disagreement (0 of 3 at p = 0.082 has
    probability 0.77; the fraction's own standard error, 0 there, called it infinitely many
    standard errors off); a transit test that can never fire (the gate 30 cm past the saddle, far
    beyond the well) is one, at 7.3 standard errors sqrt(p(1-p)/n) for 600 points: exit 2."""
    p = 0.08196                                    # p_trans at dE = 100 (docs/tubes.md)
    (tmp_path / "a.nml").write_text("&run scenes = 'montecarlo' /\n&montecarlo n_samples = 3 /\n")
    r = run_tubes(["a.nml", "-o", "a.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "a.h5") as f:
        g = f["montecarlo"]
        assert g.attrs["agrees"] == 1 and g.attrs["p_trans"] == pytest.approx(p, abs=1e-4)
        k = round(g.attrs["fraction"] * 3)
    m = re.search(r"p_trans = [0-9.]+, ([0-9.]+) standard errors", r.stdout)
    assert m and float(m.group(1)) == pytest.approx(abs(k / 3 - p) / np.sqrt(p * (1 - p) / 3), abs=0.06)
    (tmp_path / "b.nml").write_text("&run scenes = 'montecarlo' /\n&montecarlo n_samples = 600, gate = 30 /\n")
    r = run_tubes(["b.nml", "-o", "b.h5"], tmp_path)
    assert r.returncode == 2, r.stdout
    assert "the direct check disagrees with the tube" in r.stderr
    with h5py.File(tmp_path / "b.h5") as f:
        assert f["montecarlo"].attrs["agrees"] == 0 and f["montecarlo"].attrs["fraction"] == 0


def test_progress_lines_for_a_list_of_energies_come_at_most_once_a_second(tmp_path):
    """docs/usage.md: a scene's list of energies reports at most one line a second (the first
    always); it printed one per energy, about ten a second, before."""
    import time
    (tmp_path / "t.nml").write_text("&run scenes = 'transition' /\n"
                                    "&transition dE = 1, 2, 3, 5, 10, 20, 40, 60, 80, 100 /\n")
    t0 = time.monotonic()
    r = run_tubes(["t.nml", "-o", "t.h5"], tmp_path)
    secs = time.monotonic() - t0
    assert r.returncode == 0, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("transition: dE")]
    assert lines and lines[0].startswith("transition: dE = 1 (1 of 10)")
    assert len(lines) <= 1 + int(secs), (len(lines), secs)


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_seeds_reused_from_an_earlier_scene_give_the_same_bits(tmp_path, method):
    """A scene's tube cut looks up the seeds an earlier scene integrated at the same phases
    (docs/tubes.md, "Seeds computed once"): the transition and Monte Carlo results after the
    tubes scene at the same energy are bit for bit those of the scenes run alone."""
    from tubes.h5compare import compare
    common = (f"&integrator method = '{method}' /\n&tubes de = 100 /\n&transition de = 100 /\n"
              "&montecarlo n_samples = 500 /\n")
    (tmp_path / "a.nml").write_text("&run scenes = 'tubes', 'transition', 'montecarlo' /\n" + common)
    (tmp_path / "b.nml").write_text("&run scenes = 'transition', 'montecarlo' /\n" + common)
    for name in "ab":
        r = run_tubes([f"{name}.nml", "-o", f"{name}.h5"], tmp_path, threads=2)
        assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "a.h5", "a") as f:
        del f["tubes"]                               # the one scene b did not run
    assert compare(str(tmp_path / "a.h5"), str(tmp_path / "b.h5"), ignore=("input_namelist",)) == []


def test_the_energy_surface_near_the_central_maximum_has_its_area(tmp_path):
    """Up to the family's end (777.06 above S12, the central maximum R1) A_E is computed: at
    dE = 770 and 775 its derivative's quadrature fails (dA_E/dE diverges logarithmically as E
    nears the maximum the region touches), which failed the area too (status -6, NaN p_trans,
    exit 4). The area stands; p_trans = A_tube/A_E; A_E grows with dE, more and more steeply."""
    (tmp_path / "t.nml").write_text("&run scenes = 'transition' /\n&transition de = 760, 770, 775 /\n")
    r = run_tubes(["t.nml", "-o", "t.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "t.h5") as f:
        g = f["transition"]
        ae, at, pt = g["A_E"][:], g["A_tube"][:], g["p_trans"][:]
        assert list(g["status"][:]) == [0, 0, 0] and np.all(np.isfinite(ae))
        assert np.allclose(pt, at / ae, rtol=1e-15)
        d = np.diff(ae) / np.diff([760, 770, 775])
        assert np.all(d > 0) and d[1] > d[0]
