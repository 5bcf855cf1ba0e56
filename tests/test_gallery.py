"""The gallery (docs/examples, issue 37): each example run as a user runs it, in a temporary
directory given as its argument; its figure must be written and its key printed numbers must
agree with values derived independently of tubes (closed forms), where one exists."""
import math
import os
import re
import subprocess

import pytest

from conftest import ROOT

PY = str(ROOT / ".venv" / "bin" / "python")
EXAMPLES = ROOT / "docs" / "examples"


def _run(name, tmp_path):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"), MPLBACKEND="Agg")
    r = subprocess.run([PY, str(EXAMPLES / name), str(tmp_path)], cwd=tmp_path, capture_output=True, text=True,
                       timeout=300, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Traceback" not in r.stderr
    return r.stdout


def test_double_well(tmp_path):
    """Saddle at E_e = 0 (closed form), lambda = 1, omega = w = 1.3; A_tube = 2 pi dE / w and
    p_trans = dE / (dE - U(-0.5)), U(-0.5) = -0.109375, exact for the uncoupled harmonic bath;
    the Monte Carlo fraction within 4 standard errors of A_tube / A_E."""
    out = _run("double_well.py", tmp_path)
    assert (tmp_path / "double_well.png").stat().st_size > 0
    m = re.search(r"E_e = (\S+) .*lambda = (\S+) .*omega = (\S+)", out)
    assert m, out
    assert abs(float(m.group(1))) < 1e-12 and abs(float(m.group(2)) - 1) < 1e-9 and abs(float(m.group(3)) - 1.3) < 1e-9
    rows = re.findall(r"^\s*([0-9.]+)\s+([0-9.]+)\s+[0-9.]+\s+([0-9.]+)\s+([0-9.]+)\s+[0-9.]+$", out, re.M)
    assert len(rows) == 5, out
    for d, at, ae, p in ((float(v) for v in r) for r in rows):
        assert at == pytest.approx(2 * math.pi * d / 1.3, rel=1e-6)
        assert ae == pytest.approx(2 * math.pi * (d + 0.109375) / 1.3, rel=1e-6)
        assert p == pytest.approx(d / (d + 0.109375), rel=1e-5)
    m = re.search(r"Monte Carlo at dE = 0.05: (\S+) \+- (\S+) against A_tube/A_E = (\S+)", out)
    assert m and abs(float(m.group(1)) - 0.05 / 0.159375) < 4 * float(m.group(2)), out


def test_henon_heiles(tmp_path):
    """The three saddles at energy 1/6 on the unit circle and the well at 0 (closed form), and a
    section with returns."""
    out = _run("henon_heiles.py", tmp_path)
    assert (tmp_path / "henon_heiles.png").stat().st_size > 0
    sad = re.findall(r"^S\d: .* energy (\S+), index 1, \|q\| = (\S+)$", out, re.M)
    assert len(sad) == 3, out
    for e, r in sad:
        assert float(e) == pytest.approx(1 / 6, abs=1e-10) and float(r) == pytest.approx(1.0, abs=1e-6)
    m = re.search(r"(\d+) returns, (\d+) of 30 seeds escaped", out)
    assert m and int(m.group(1)) > 0, out


def test_parameter_scan(tmp_path):
    """At dE = 2 the tube's cut is the Lyapunov orbit's action to leading order, 2 pi dE / omega:
    the ratio within 1e-3 of 1 for every alpha; p_trans grows with dE (2 -> 20) by about 10."""
    out = _run("parameter_scan.py", tmp_path)
    assert (tmp_path / "parameter_scan.png").stat().st_size > 0
    rows = re.findall(r"^\s*(0\.\d+)\s+\S+\s+\S+\s+(\S+)\s+(\S+)\s+(\S+)$", out, re.M)
    assert len(rows) == 4, out
    for a, p2, p20, ratio in rows:
        assert abs(float(ratio) - 1) < 1e-3, (a, ratio)
        assert 8 < float(p20) / float(p2) < 11, (a, p2, p20)


def test_lab_data(tmp_path):
    """A trackpy-style export read with time_unit='frame': the energy balance within 0.02 of 1 and
    the true damping ratio 0.025 inside the printed 95 % interval."""
    out = _run("lab_data.py", tmp_path)
    assert (tmp_path / "lab_data.png").stat().st_size > 0 and (tmp_path / "lab_tracks.csv").exists()
    m = re.search(r"g H falls by (\S+) times", out)
    assert m and abs(float(m.group(1)) - 1) < 0.02, out
    m = re.search(r"\(95 %: (\S+) \.\. (\S+); true 0.025\)", out)
    assert m and float(m.group(1)) <= 0.025 <= float(m.group(2)), out


def test_cr3bp_l1(tmp_path):
    """L1 against the collinear quintic's root between the primaries (scipy's brentq) and its
    energy U_eff(L1); the cut's area equal to the action (1e-8) and within 1 % of its leading
    order 2 pi dE / omega; the polygon area within 1e-5."""
    from scipy.optimize import brentq
    out = _run("cr3bp_l1.py", tmp_path)
    assert (tmp_path / "cr3bp_l1.png").stat().st_size > 0
    m = re.search(r"mu = (\S+): L1 at x = (\S+), energy (\S+),", out)
    assert m, out
    mu, x, e = (float(v) for v in m.groups())
    xl1 = brentq(lambda x: x - (1 - mu) / (x + mu) ** 2 + mu / (x - 1 + mu) ** 2, 0.5, 1 - mu - 1e-3, xtol=1e-15)
    assert x == pytest.approx(xl1, abs=1e-9)
    assert e == pytest.approx(-xl1 ** 2 / 2 - (1 - mu) / (xl1 + mu) - mu / (1 - mu - xl1), abs=1e-9)
    m = re.search(r"area (\S+) \(polygon (\S+)\), action (\S+), .*= (\S+)$", out, re.M)
    area, poly, action, lead = (float(v) for v in m.groups())
    assert area == pytest.approx(action, rel=1e-8) and poly == pytest.approx(area, rel=1e-5)
    assert area == pytest.approx(lead, rel=1e-2)


def test_flux_3dof(tmp_path):
    """The quadratic saddle (e = 0): the leading order equals sqrt(2) pi^2 dE^2 (closed form) and
    the sampled flux agrees with it within 4 standard errors; the quartic bath (e = 0.3) lowers
    the sampled flux at the largest dE (same samples)."""
    out = _run("flux_3dof.py", tmp_path)
    assert (tmp_path / "flux_3dof.png").stat().st_size > 0
    rows = [tuple(float(v) for v in r) for r in
            re.findall(r"^\s*(0\.0|0\.3)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)$", out, re.M)]
    assert len(rows) == 6, out
    for e, d, s, se, lo, cf in rows:
        assert lo == pytest.approx(math.sqrt(2) * math.pi ** 2 * d * d, rel=1e-5)
        if e == 0.0:
            assert abs(s - lo) < 4 * se, (d, s, se, lo)
    assert rows[5][2] < rows[2][2]


def test_damped_region(tmp_path):
    """Continuity as zeta -> 0 (the region at zeta = 1e-6 within 1e-3 of the conservative cut's
    area) and the region shrinking as the damping grows."""
    out = _run("damped_region.py", tmp_path)
    assert (tmp_path / "damped_region.png").stat().st_size > 0
    ratios = [float(v) for v in re.findall(r"ratio to the cut (\S+),", out)]
    assert len(ratios) == 3, out
    assert abs(ratios[0] - 1) < 1e-3 and ratios[0] > ratios[1] > ratios[2] > 0, ratios


def test_halo_branch(tmp_path):
    """The L1 and L2 halo branch points as the example prints them: one each, nu_v = 1 there, C
    within 1e-10 of tests/test_bifurcations.py's scipy values (3.174351954078, 3.152118903101;
    that test states the agreement) plus the program's own 7.6e-11."""
    out = _run("halo_branch.py", tmp_path)
    assert (tmp_path / "halo_branch.png").stat().st_size > 0
    rows = re.findall(r"^(L[12]): kind 1 \(branch point\) at dE = \S+, C = (\S+), period \S+, nu = \S+, (\S+)$", out, re.M)
    assert [r[0] for r in rows] == ["L1", "L2"], out
    for (_, c, nu), ref in zip(rows, (3.174351954078, 3.152118903101)):
        assert abs(float(c) - ref) < 2e-10 and abs(float(nu) - 1) < 1e-8


def test_halo_l1(tmp_path):
    """The L1 halo families as the example prints them: north and south mirror images (z0 -> -z0,
    the same C and period), C = -2 (E_L1 + dE) with E_L1 = -1.594170558874... (C(dE) - C(dE') =
    -2 (dE - dE')), the period growing with dE; tests/test_halo.py checks the orbits against scipy."""
    out = _run("halo_l1.py", tmp_path)
    assert (tmp_path / "halo_l1.png").stat().st_size > 0
    rows = re.findall(r"^(halo_\w+): dE = (\S+), C = (\S+), period (\S+), z0 = (\S+)$", out, re.M)
    n = [r for r in rows if r[0] == "halo_north"]
    s = [r for r in rows if r[0] == "halo_south"]
    assert len(n) == len(s) == 6, out
    for a, b in zip(n, s):
        assert a[1:4] == b[1:4] and float(a[4]) == pytest.approx(-float(b[4]), abs=1e-8)
    de = [float(r[1]) for r in n]
    c = [float(r[2]) for r in n]
    for k in range(1, 6):
        assert c[k] - c[0] == pytest.approx(-2 * (de[k] - de[0]), abs=1e-9)
    assert all(float(n[k][3]) > float(n[k - 1][3]) for k in range(1, 6))


def test_axial_l1(tmp_path):
    """The L1 axial family as the example prints it: six orbits between the two branch points, C =
    -2 (E_L1 + dE) (C(dE) - C(dE') = -2 (dE - dE')), the period growing with dE, out of the plane
    with vz0 < 0 (the positive tilt's side); the period at dE = 0.09 the one tests/test_axial.py
    checks against scipy (3.999031411744, to 1e-9)."""
    out = _run("axial_l1.py", tmp_path)
    assert (tmp_path / "axial_l1.png").stat().st_size > 0
    rows = re.findall(r"^axial: dE = (\S+), C = (\S+), period (\S+), x0 = \S+, vy0 = \S+, vz0 = (\S+)$", out, re.M)
    assert len(rows) == 6, out
    de, c, t, vz = ([float(r[i]) for r in rows] for i in range(4))
    for k in range(1, 6):
        assert c[k] - c[0] == pytest.approx(-2 * (de[k] - de[0]), abs=1e-9)
        assert t[k] > t[k - 1]
    assert all(v < -0.1 for v in vz)
    assert t[de.index(0.09)] == pytest.approx(3.999031411744, abs=1e-9)
