"""The orbits scene through the executable: output contract, refusal past the family's end
(message with the limiting dE, exit code 4, the other energies written), the plots."""
import h5py
import numpy as np

import tubes
from conftest import run_tubes


def test_auto_with_h_keeps_the_variational_integration_adaptive(tmp_path, tubes_exe):
    """Under method = 'auto', &integrator h is the Taylor method's largest step; the orbits'
    variational equations run DOP853, which took h as a fixed step without error control (the
    action at dE = 10 off by 3e-6 relative at h = 0.15, exit 0). Now the same orbits as h = 0."""
    acts = []
    for h in (0.0, 0.15):
        (tmp_path / "a.nml").write_text(f"&run scenes = 'orbits' /\n&integrator h = {h} /\n&orbits de = 1, 10 /\n")
        r = run_tubes(["a.nml", "-o", "a.h5"], tmp_path)
        assert r.returncode == 0, r.stderr
        with h5py.File(tmp_path / "a.h5") as f:
            acts.append(f["orbits/action"][:])
    assert np.allclose(acts[0], acts[1], rtol=1e-9, atol=0), acts


def test_an_energy_short_of_the_extrapolated_end_is_not_called_past_it(tmp_path, tubes_exe):
    """De Leon-Berne's Morse family ends at dE = D = 10 (the period grows like -log(D - dE)); the
    continuation stops at its limit on the period, before dE = 9.98 (T = 59.24 by the closed form),
    and extrapolates the end to about 9.99. dE = 9.98 is below that: not 'past the end' (the
    message said so, naming an end above it), but not reached."""
    (tmp_path / "d.nml").write_text("&run scenes = 'orbits' /\n&model system = 'de_leon_berne' /\n"
                                    "&orbits de = 9.95, 9.98 /\n")
    r = run_tubes(["d.nml", "-o", "d.h5"], tmp_path)
    assert r.returncode == 4, r.stderr
    assert "dE = 9.98 was not reached: the continuation of the S1 family stopped before it" in r.stderr, r.stderr
    assert "past the end" not in r.stderr, r.stderr
    with h5py.File(tmp_path / "d.h5") as f:
        o = f["orbits"]
        assert list(o["converged"][:]) == [1, 0]
        assert 9.98 < o.attrs["family_end_dE"] < 10.0 + 1e-9


def test_orbits_scene_and_family_end(tmp_path, tubes_exe):
    (tmp_path / "o.nml").write_text("&run scenes = 'equilibria', 'orbits' /\n"
                                    "&orbits de = 1, 100, 800, method = 'multiple', n_segments = 4 /\n")
    r = run_tubes(["o.nml", "-o", "o.h5"], tmp_path)
    assert r.returncode == 4, r.stderr                       # partial: dE = 800 refused
    assert "dE = 800 is past the end of the S12 family" in r.stderr
    assert "777.06" in r.stderr                              # the limit, E(R1) - E_e = 777.0625
    with h5py.File(tmp_path / "o.h5") as f:
        o = f["orbits"]
        assert list(o["converged"][:]) == [1, 1, 0]
        assert abs(o.attrs["family_end_dE"] - 777.0625) < 0.1
        eq = f["equilibria"]
        names = [n.decode() for n in eq["name"][:]]
        e_r1 = eq["energy"][names.index("R1")]
        assert abs(o.attrs["family_end_dE"] - (e_r1 - f["saddle"].attrs["energy"])) < 0.1
        # periods near T_po; the first orbit's action close to T_po dE (MacKay)
        t_po = f["saddle"].attrs["T_po"]
        assert abs(o["period"][0] - t_po) < 1e-3 and abs(o["action"][0] / (t_po * 1.0) - 1) < 1e-3
        assert o["orbit_000/state"].shape == (201, 4)
        assert np.allclose(o["mu_unstable"][:2] * o["mu_stable"][:2], 1, rtol=1e-8)


def test_orbit_plots(tmp_path, tubes_exe):
    (tmp_path / "o.nml").write_text("&run scenes = 'equilibria', 'orbits' /\n&orbits de = 10, 200 /\n")
    assert run_tubes(["o.nml", "-o", "o.h5"], tmp_path).returncode == 0
    from tubes import plots
    assert plots.main([str(tmp_path / "o.h5"), "-o", str(tmp_path / "fig")]) == 0
    for name in ["orbit_family.png", "orbit_properties.png"]:
        p = tmp_path / "fig" / name
        assert p.stat().st_size > 10_000
    res = tubes.load(str(tmp_path / "o.h5"))
    assert res.orbits.orbit_001.state.shape == (201, 4)


def test_orbits_identical_for_1_and_2_threads(tmp_path, tubes_exe):
    """Multiple-shooting segments run in parallel; the result must not depend on the threads."""
    import os
    import subprocess
    (tmp_path / "o.nml").write_text("&run scenes = 'orbits' /\n"
                                    "&orbits de = 5, 300, method = 'multiple', n_segments = 6 /\n")
    out = {}
    for nt in (1, 2):
        env = dict(os.environ, OMP_NUM_THREADS=str(nt))
        r = subprocess.run([tubes_exe, "o.nml", "-o", f"t{nt}.h5"], cwd=tmp_path, env=env,
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        with h5py.File(tmp_path / f"t{nt}.h5") as f:
            out[nt] = {k: f["orbits"][k][()] for k in ["period", "action", "state0", "monodromy", "residual"]}
    for k in out[1]:
        assert np.array_equal(out[1][k], out[2][k]), k         # bitwise


def test_an_integration_too_coarse_for_the_orbit_is_said(tmp_path):
    """RK4 with h = 0.05 (15 steps a period) converges the shooting on its own map (residual 3e-12)
    while one period's closure, mu_unstable times the integration error, is 1.5e-3: the orbit's
    digits are not the flow's (action 75.7246 against 75.7848 with h = 0.001, whose closure is
    2e-12). Said on stderr, exit 2; the fine step passes."""
    for h, code in [(0.05, 2), (0.001, 0)]:
        (tmp_path / "r.nml").write_text(f"&run scenes = 'orbits' /\n&orbits de = 100 /\n"
                                        f"&integrator method = 'rk4', h = {h} /\n")
        r = run_tubes(["r.nml", "-o", f"r{code}.h5"], tmp_path)
        assert r.returncode == code and (("too coarse" in r.stderr) == (code == 2)), r.stderr
    with h5py.File(tmp_path / "r2.h5") as f, h5py.File(tmp_path / "r0.h5") as g:
        assert abs(f["orbits/action"][0] / g["orbits/action"][0] - 1) > 1e-4     # the coarse one is off
        assert f["orbits/closure"][0] / f["orbits/mu_unstable"][0] > 1e-8 * 6
