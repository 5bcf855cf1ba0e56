"""The paper's counts (issue 17): the synthetic experiment with the &experiment defaults (120
tracks of 14 s, zeta = 0.014, released at dE 1000..3000) analysed with the quadrants folded
(`--fold all`) gives about the paper's 4000 crossings and 400 transitions, and the slope within 3
standard errors of the theory in the same bins. The folding itself: the crossings it finds are
the diagonal crossings counted naively on the noise-free truth; the exact images are exact (the
tracks mirrored by a symmetry of the surface give the same crossings); the other quadrants' wells
differ (their section's theory is the mirror surface's)."""
import os
import subprocess

import h5py
import numpy as np
import pytest

import tubes.experiment as ex
from conftest import ROOT, TUBES

PY = str(ROOT / ".venv" / "bin" / "python")


def _tubes(cwd, name, text):
    (cwd / f"{name}.nml").write_text(text)
    r = subprocess.run([str(TUBES), f"{name}.nml", "-o", f"{name}.h5"], cwd=cwd, capture_output=True,
                       text=True, timeout=300, env=dict(os.environ, OMP_NUM_THREADS="2"))
    assert r.returncode == 0, r.stderr
    return cwd / f"{name}.h5"


def _cli(args, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"))
    return subprocess.run([PY, "-m", "tubes.experiment", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300, env=env)


@pytest.fixture(scope="module")
def paper_like(tmp_path_factory):
    d = tmp_path_factory.mktemp("fold")
    h5 = _tubes(d, "p", "&run scenes = 'synthetic_experiment', 'tubes', 'transition' /\n"
                        "&tubes de = 100, 140, 200, 400, area_tol = 1e-6 /\n"
                        "&transition de = 1, 20, 40, 80, 120, 160, 200, 300, 400, area_tol = 1e-6 /\n")
    q24 = _tubes(d, "q", "&run scenes = 'transition' /\n&orbits saddle = 'S23' /\n&section angle = 135 /\n"
                         "&transition de = 1, 20, 40, 80, 120, 160, 200, 300, 400, area_tol = 1e-6 /\n")
    r = _cli([str(h5), "--theory", str(h5), "--fold", "all", "--theory-q24", str(q24), "--resamples", "0",
              "--bootstrap", "200", "-o", "a.h5"], d)
    assert r.returncode == 0, r.stderr
    with h5py.File(d / "a.h5") as f:
        attrs = dict(f["experiment"].attrs)
        image = f["experiment/crossings/image"][()]
    return d, h5, attrs, image, r.stdout


def test_the_paper_counts_and_slope(paper_like):
    """~4000 crossings and ~400 transitions (within 25 %) from 120 tracks; the slope of quadrants 1
    and 3 within 3 standard errors of the theory's (the damping biases it low: docs/paper.md);
    the damping comes back within its interval."""
    _, _, a, _, out = paper_like
    assert a["fold"] == "all"
    assert 3000 <= a["n_folded_crossings"] <= 5000, a["n_folded_crossings"]
    assert 300 <= a["n_folded_transitions"] <= 500, a["n_folded_transitions"]
    assert abs(a["slope"] - a["slope_theory"]) < 3 * a["slope_err"], (a["slope"], a["slope_err"], a["slope_theory"])
    assert abs(a["damping_ratio"] - 0.014) < 4 * a["damping_ratio_err"]
    assert "folded (all: the four diagonals, both ways)" in out and "Q2+Q4" in out


def test_quadrants_2_and_4_against_their_own_theory(paper_like):
    """--theory-q24 (the diagonal of quadrant 2 through S23) gives the q24 table its theory: about
    twice U1's (1.5 to 1.9 times; test_quadrant_2_is_the_mirror_surface), and the fraction there
    within 3 standard errors of it. A theory on the wrong diagonal is refused, each way."""
    d, h5, a, _, out = paper_like
    assert 1.4 < a["q24_slope_theory"] / a["slope_theory"] < 2.0
    assert abs(a["q24_slope"] - a["q24_slope_theory"]) < 3 * a["q24_slope_err"], (a["q24_slope"], a["q24_slope_err"])
    assert "quadrants 2 and 4: slope" in out
    r = _cli([str(h5), "--theory", str(d / "q.h5"), "--resamples", "0", "--bootstrap", "0"], d)
    assert r.returncode == 1 and "the ray at 135 deg" in r.stderr and "--theory needs U1" in r.stderr, r.stderr
    r = _cli([str(h5), "--fold", "all", "--theory-q24", str(h5), "--resamples", "0", "--bootstrap", "0"], d)
    assert r.returncode == 1 and "the ray at 45 deg" in r.stderr, r.stderr


def test_fold_finds_the_true_diagonal_crossings(paper_like):
    """Every crossing of the four diagonals after t_skip, counted by sign changes of y - x and y + x
    on the noise-free states (no smoothing, no interpolation), is found once by the folded
    analysis of the noisy tracks (to 1 %: crossings near a segment end, or a graze)."""
    _, h5, a, image, _ = paper_like
    with h5py.File(h5) as f:
        tr, t, st = f["tracks/track"][()], f["tracks/t"][()], f["tracks/truth/state"][()]
    n = 0
    for k in np.unique(tr):
        s = (tr == k) & (t >= ex.T_SKIP)
        x, y = st[s, 0], st[s, 1]
        for g, side in ((y - x, x + y), (y + x, x - y)):     # the lines y = x and y = -x, both rays
            n += int(np.sum((np.sign(g[:-1]) != np.sign(g[1:])) & (side[:-1] != 0)))
    print(f"folded analysis {image.size}, naive count on the truth {n}")
    assert abs(image.size - n) <= 0.01 * n, (image.size, n)
    assert set(np.unique(image)) == set(range(8))


def test_exact_images_are_exact(paper_like):
    """The surface is symmetric under (x, y) -> (y, x) and (x, y) -> (-x, -y): tracks mirrored by
    either give, with --fold exact, the same crossings (count, dE to round-off, outcomes)."""
    _, h5, _, _, _ = paper_like
    tr = ex.read_tracks(str(h5))
    keep = tr.track < 30
    base = ex.Tracks(tr.track[keep], tr.t[keep], tr.x[keep], tr.y[keep], dict(tr.attrs), source=str(h5))
    opt = ex.Options(fold="exact", resamples=0, bootstrap=0, compare=False)
    ref = ex.analyse(base, None, opt).crossings
    order = np.lexsort((ref["t"], ref["track"]))
    for mx, my in ((base.y, base.x), (-base.x, -base.y)):
        mirrored = ex.Tracks(base.track, base.t, mx.copy(), my.copy(), dict(base.attrs), source="mirrored")
        c = ex.analyse(mirrored, None, opt).crossings
        o = np.lexsort((c["t"], c["track"]))
        assert c["t"].size == ref["t"].size
        np.testing.assert_allclose(c["t"][o], ref["t"][order], rtol=0, atol=1e-9)
        np.testing.assert_allclose(c["dE"][o], ref["dE"][order], rtol=0, atol=1e-7)
        assert np.array_equal(c["outcome"][o], ref["outcome"][order])


def test_quadrant_2_is_the_mirror_surface(tmp_path):
    """The diagonal of quadrant 2 (theta = 135 deg, through S23) of the surface is U1 of its mirror
    image (xi -> -xi): the same p_trans to 1e-9, and about twice quadrant 1's at small dE (its well
    is 486 (cm/s)^2 shallower): why --fold all keeps quadrants 2 and 4 apart."""
    def p(name, text):
        with h5py.File(_tubes(tmp_path, name, "&run scenes = 'transition' /\n&transition de = 10, 100 /\n"
                                          + text)) as f:
            return f["transition/p_trans"][()]
    q1 = p("q1", "")
    q2 = p("q2", "&orbits saddle = 'S23' /\n&section angle = 135 /\n")
    mirror = p("m", "&model xi = -0.00656 /\n")
    np.testing.assert_allclose(q2, mirror, rtol=1e-9)
    assert 1.7 < q2[0] / q1[0] < 2.0 and 1.6 < q2[1] / q1[1] < 1.9


def test_theory_q24_needs_the_fold(paper_like):
    """--theory-q24 belongs to --fold all: without it, exit 1 naming the option."""
    d, h5, _, _, _ = paper_like
    r = _cli([str(h5), "--theory-q24", str(d / "q.h5"), "--resamples", "0", "--bootstrap", "0"], d)
    assert r.returncode == 1 and "give --fold all" in r.stderr, r.stderr
