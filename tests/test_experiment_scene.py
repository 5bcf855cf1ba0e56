"""The synthetic_experiment scene through the executable (docs/experiment-data.md): the /tracks
contract, the truth against the damped dynamics (dE/dt = -2 c T from the stored momenta), the
pixel grid, the noise statistics, determinism for 1 and 2 threads, the CSV copy, bad input; and
tubes.differentiate through the Python boundary."""
import os
import re
import subprocess

import h5py
import numpy as np
import pytest

import tubes
from conftest import ROOT, TUBES, run_tubes

N_TRACKS = 6
ALPHA, BETA, GAMMA, XI, H0, G = 0.07, 1.017, 15.103, 0.00656, 12.065, 981.0


def _run(tmp_path, text, name="e", threads=1):
    (tmp_path / f"{name}.nml").write_text(text)
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    return subprocess.run([str(TUBES), f"{name}.nml", "-o", f"{name}.h5"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120, env=env)


@pytest.fixture(scope="module")
def run(tmp_path_factory, tubes_exe):
    d = tmp_path_factory.mktemp("exp")
    r = _run(d, f"&run scenes = 'synthetic_experiment' /\n"
                f"&experiment n_tracks = {N_TRACKS}, csv = 'tracks.csv' /\n")
    assert r.returncode == 0, r.stderr
    with h5py.File(d / "e.h5") as f:
        data = {k: f["tracks"][k][()] for k in ("track", "t", "x", "y")}
        data.update({k: f["tracks/truth"][k][()] for k in f["tracks/truth"]})
        data["attrs"] = dict(f["tracks"].attrs)
        data["units"] = {k: f["tracks"][k].attrs["units"] for k in ("track", "t", "x", "y")}
        names = []
        f["tracks"].visit(names.append)
        data["names"] = names
    data["dir"] = d
    return data


def _height(x, y):
    return ALPHA * (x**2 + y**2) - BETA * (np.sqrt(x**2 + GAMMA) + np.sqrt(y**2 + GAMMA)) - XI * x * y + H0


def _kinetic(s):
    """T = (5/14)(|p|^2 - (grad H . p)^2 / (1 + |grad H|^2)) (docs/theory.md), from the state."""
    x, y, px, py = s.T
    hx = 2 * ALPHA * x - BETA * x / np.sqrt(x**2 + GAMMA) - XI * y
    hy = 2 * ALPHA * y - BETA * y / np.sqrt(y**2 + GAMMA) - XI * x
    sp = hx * px + hy * py
    return 5 / 14 * (px**2 + py**2 - sp**2 / (1 + hx**2 + hy**2))


def test_contract(run):
    """/tracks as docs/output.md promises: flat columns sorted by track then time."""
    a = run["attrs"]
    ns = int(a["n_samples"])
    n = N_TRACKS * ns
    assert ns == 701                                   # 14 s at 50 Hz, both ends
    assert run["track"].dtype == np.int32 and run["track"].shape == (n,)
    for k in ("t", "x", "y", "energy", "dE"):
        assert run[k].shape == (n,) and run[k].dtype == np.float64
    assert run["state"].shape == (n, 4) and run["noisy"].shape == (n, 2)
    assert run["release"].shape == (N_TRACKS, 2) and run["release_dE"].shape == (N_TRACKS,)
    assert run["units"] == {"track": "1", "t": "s", "x": "cm", "y": "cm"}
    for k in ["camera_rate", "pixel", "noise", "damping_ratio", "seed", "n_tracks", "de_min",
              "de_max", "E_e", "damping_rate", "n_samples", "duration", "saddle", "box", "rtol",
              "n_draws", "status"]:
        assert k in a, k
    assert (a["camera_rate"], a["pixel"], a["noise"], a["damping_ratio"], a["n_tracks"],
            a["de_min"], a["de_max"], a["seed"], a["duration"]) == (50, 0.16, 0.05, 0.014, N_TRACKS, 1000, 3000, 2018, 14)
    assert a["status"] == 0 and a["saddle"] == "S12"
    assert np.array_equal(run["track"], np.repeat(np.arange(N_TRACKS), ns))
    t = run["t"].reshape(N_TRACKS, ns)
    assert np.all(t == t[0])                                            # one frame grid
    assert np.allclose(t[0], np.arange(ns) / 50.0, rtol=0, atol=1e-13)  # k dt, dt = 1/50 rounded
    # E_e is the S12 saddle's energy (tubes.equilibria, an independent Newton solve)
    eq = tubes.equilibria()
    assert a["E_e"] == pytest.approx(eq["energy"][eq["name"].index("S12")], rel=1e-12)


def test_releases(run):
    """Each track starts at rest at its release point, with g H - E_e in [de_min, de_max]."""
    a = run["attrs"]
    ns = int(a["n_samples"])
    s0 = run["state"][::ns]
    assert np.array_equal(s0[:, :2], run["release"]) and np.all(s0[:, 2:] == 0)
    assert np.all(np.abs(run["release"]) <= 13)
    de = G * _height(*run["release"].T) - a["E_e"]
    assert np.allclose(de, run["release_dE"], rtol=0, atol=1e-9)   # roundoff of g H ~ 6e3
    assert np.all((de >= 1000) & (de <= 3000))
    assert np.allclose(run["dE"][::ns], de, rtol=0, atol=1e-9)
    assert a["n_draws"] >= N_TRACKS


def test_damping_rate(run):
    """c = 2 zeta omega_1, omega_1^2 = (5/7) g kappa_min at the lowest well (docs/theory.md)."""
    eq = tubes.equilibria()
    wells = [i for i, m in enumerate(eq["morse_index"]) if m == 0]
    w = min(wells, key=lambda i: eq["energy"][i])
    x, y = eq["x"][w], eq["y"][w]
    hess = np.array([[2 * ALPHA - BETA * GAMMA / (x**2 + GAMMA)**1.5, -XI],
                     [-XI, 2 * ALPHA - BETA * GAMMA / (y**2 + GAMMA)**1.5]])
    omega1 = np.sqrt(5 / 7 * G * np.linalg.eigvalsh(hess)[0])
    assert run["attrs"]["damping_rate"] == pytest.approx(2 * 0.014 * omega1, rel=1e-9)


def test_truth_energy_decays_as_damping_implies(run):
    """dE/dt = -2 c T (docs/theory.md, damping): E(t_k+4) - E(t_k) = -2 c int T dt over each block
    of 4 frames, the integral by Simpson's rule on T computed from the stored momenta. Simpson's
    error is at most (4 dt) dt^4 / 180 max|T''''| per block; max|T''''| is estimated from the data
    as the largest 4th difference |Delta^4 T| / dt^4 around the block (samples 4b-2 .. 4b+8;
    measured: the residuals reach 0.996 of that estimate). The check allows 2x it (the 4th
    difference is T'''' only to O(dt^2)) plus the integration error (rtol 1e-10 of E ~ 5e3)."""
    a = run["attrs"]
    ns, c, dt = int(a["n_samples"]), a["damping_rate"], 1 / a["camera_rate"]
    e = run["energy"].reshape(N_TRACKS, ns)
    s = run["state"].reshape(N_TRACKS, ns, 4)
    worst = 0.0
    for j in range(N_TRACKS):
        tk = _kinetic(s[j])
        # the stored energy is T + g H of the stored state
        assert np.allclose(e[j], tk + G * _height(s[j, :, 0], s[j, :, 1]), rtol=1e-12, atol=0)
        m = (ns - 1) // 4 * 4                          # whole blocks of 4 intervals
        de4 = e[j, 4:m + 1:4] - e[j, 0:m - 3:4]
        s_h = dt / 3 * (tk[0:m - 3:4] + 4 * tk[1:m - 2:4] + 2 * tk[2:m - 1:4] + 4 * tk[3:m:4] + tk[4:m + 1:4])
        d4 = np.abs(np.diff(tk, 4))                    # d4[i] ~ |T''''(t_(i+2))| dt^4
        env = np.array([d4[max(0, 4 * b - 2):4 * b + 5].max() for b in range(len(de4))])
        tol = 2 * (2 * c * 4 * dt / 180 * env) + 1e-6
        resid = np.abs(de4 + 2 * c * s_h)
        assert np.all(resid <= tol), (j, np.max(resid / tol))
        worst = max(worst, np.max(resid / tol))
        # the check has teeth: a damping rate 1 % off violates it on most blocks
        assert np.mean(np.abs(de4 + 2 * 1.01 * c * s_h) > tol) > 0.5
        assert np.all(np.diff(e[j]) < 0)               # T > 0 after the release: E decreases
    print(f"largest residual / tolerance of the energy balance: {worst:.3f}")


def test_pixel_grid(run):
    """Measured positions are the noisy ones rounded half away from zero to the pixel grid."""
    pix = run["attrs"]["pixel"]
    for k, col in (("x", 0), ("y", 1)):
        q = run[k] / pix
        assert np.max(np.abs(q - np.round(q))) < 1e-9
        v = run["noisy"][:, col]
        assert np.array_equal(run[k], np.sign(v) * np.floor(np.abs(v) / pix + 0.5) * pix)
        assert np.max(np.abs(run[k] - v)) <= pix / 2 * (1 + 1e-12)


def test_noise_statistics(run):
    """noisy - true position: N(0, noise^2), independent. With N = 2 n samples the sample standard
    deviation has relative sd 1/sqrt(2 N) and the mean sd noise/sqrt(N); correlations have sd
    1/sqrt(N); the fraction inside one sigma (0.6827) has sd sqrt(p(1-p)/N). Each within 5 sd."""
    sigma = run["attrs"]["noise"]
    r = run["noisy"] - run["state"][:, :2]
    n = r.size
    assert abs(r.std() / sigma - 1) <= 5 / np.sqrt(2 * n)
    assert abs(r.mean()) <= 5 * sigma / np.sqrt(n)
    assert abs(np.corrcoef(r[:, 0], r[:, 1])[0, 1]) <= 5 / np.sqrt(n / 2)
    assert abs(np.corrcoef(r[:-1, 0], r[1:, 0])[0, 1]) <= 5 / np.sqrt(n / 2)
    p = 0.6826894921370859
    assert abs(np.mean(np.abs(r) < sigma) - p) <= 5 * np.sqrt(p * (1 - p) / n)


def test_csv_is_the_same_data(run):
    path = run["dir"] / "tracks.csv"
    assert path.read_text().splitlines()[0] == "track,t,x,y"
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    assert np.array_equal(d[:, 0].astype(np.int32), run["track"])
    for i, k in ((1, "t"), (2, "x"), (3, "y")):      # 12 significant digits
        assert np.allclose(d[:, i], run[k], rtol=1e-11, atol=1e-12)


def test_documented(run):
    """Every object and attribute of /tracks is in docs/output.md; every &experiment variable is in
    docs/input.md and the scene in both."""
    out = (ROOT / "docs" / "output.md").read_text()
    for name in set(n.split("/")[-1] for n in run["names"]) | set(run["attrs"]) | {"tracks"}:
        assert f"`{name}`" in out or f"`/{name}`" in out, name
    inp = (ROOT / "docs" / "input.md").read_text()
    assert "## `&experiment`" in inp and "`synthetic_experiment`" in inp
    for v in ["n_tracks", "duration", "camera_rate", "pixel", "noise", "de_min", "de_max",
              "damping_ratio", "seed", "csv"]:
        assert re.search(rf"\| `{v}` \|", inp.split("## `&experiment`")[1]), v
    assert (ROOT / "docs" / "experiment-data.md").exists()


def test_threads_do_not_change_the_data(tmp_path, tubes_exe):
    """The random numbers are drawn serially and each track is integrated into its own slice."""
    text = "&run scenes = 'synthetic_experiment' /\n&experiment n_tracks = 8, duration = 3 /\n"
    for th in (1, 2):
        r = _run(tmp_path, text, name=f"t{th}", threads=th)
        assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "t1.h5") as f1, h5py.File(tmp_path / "t2.h5") as f2:
        names = []
        f1["tracks"].visit(names.append)
        for k in names:
            if isinstance(f1["tracks"][k], h5py.Dataset):
                assert np.array_equal(f1["tracks"][k][()], f2["tracks"][k][()]), k
    # and a different seed gives different data
    r = _run(tmp_path, text.replace("duration = 3", "duration = 3, seed = 7"), name="s7")
    with h5py.File(tmp_path / "t1.h5") as f1, h5py.File(tmp_path / "s7.h5") as f2:
        assert not np.array_equal(f1["tracks/x"][()], f2["tracks/x"][()])


def test_impossible_energy_band(tmp_path, tubes_exe):
    """g H - E_e <= 5756 (cm/s)^2 in the box (its corners (13, -13), (-13, 13)): no release point
    exists above it."""
    r = _run(tmp_path, "&run scenes = 'synthetic_experiment' /\n"
                       "&experiment n_tracks = 2, de_min = 6000, de_max = 7000 /\n")
    assert r.returncode == 2, r.stderr
    assert "fewer than 2 release points" in r.stderr and "widen" in r.stderr


# ------------------------------------------------------------------ tubes.differentiate
def test_differentiate_python():
    """Through the f2py boundary: Savitzky-Golay is exact on a cubic (roundoff ~1e-12 of
    |x| sum|w1| / dt), the periodic spectral derivative exact on a band-limited signal, columns of
    2-D input are differentiated independently, bad options raise."""
    dt = 0.02
    t = np.arange(501) * dt
    s = (t - 5) / 5
    x = 1 - s / 2 + s**2 / 3 - s**3 / 4
    v_true = (-1 / 2 + 2 * s / 3 - 3 * s**2 / 4) / 5
    v, xs = tubes.differentiate(x, dt, "savgol", order=3, window=11)
    assert np.max(np.abs(v - v_true)) < 1e-10 and np.max(np.abs(xs - x)) < 1e-12
    tp = np.arange(500) * dt
    w = 2 * np.pi * np.array([3, 47]) / 10.0
    xp = np.column_stack([np.sin(w[0] * tp), np.cos(w[1] * tp)])
    vp, _ = tubes.differentiate(xp, dt, cutoff=None, edge="periodic")
    assert vp.shape == (500, 2)
    assert np.max(np.abs(vp[:, 0] - w[0] * np.cos(w[0] * tp))) < 1e-11
    assert np.max(np.abs(vp[:, 1] + w[1] * np.sin(w[1] * tp))) < 1e-11
    v2, _ = tubes.differentiate(xp[:, 1], dt, cutoff=None, edge="periodic")
    assert np.array_equal(v2, vp[:, 1])
    with pytest.raises(TypeError):
        tubes.differentiate(x, dt, "savgol", cutoff=3)
    with pytest.raises(ValueError):
        tubes.differentiate(x, dt, edge="reflect")
    with pytest.raises(tubes.TubesError):
        tubes.differentiate(x, dt, "savgol", window=12)
