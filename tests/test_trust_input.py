"""Issue 39, the input side: nothing silently misread, no work larger than the machine, no NaN
column in the 3-DOF flux scene. Each case failed before (the value, exit code or output it gave
then is in the comment) and is refused, or reported, now."""
import os
import resource
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import ROOT, TUBES, run_tubes


def check(tmp_path, text, name="in.nml", limit_as=None):
    p = tmp_path / name
    p.write_text(text)

    def lower():
        if limit_as:
            resource.setrlimit(resource.RLIMIT_AS, (limit_as, limit_as))
    return subprocess.run([str(TUBES), "--check", p.name], cwd=tmp_path, capture_output=True, text=True,
                          timeout=60, preexec_fn=lower)


@pytest.mark.parametrize("value", ["0x1p-4/", "0x1p-4 /", "0x1p-4\n/", "0X10/", "1e/", "./"])
def test_a_hex_or_malformed_real_is_refused(tmp_path, value):
    # "dt_out = 0x1p-4/" kept the default 0.01, exit 0 (C's strtod reads hex; Fortran's READ does not)
    r = check(tmp_path, "&run scenes = 'trajectory' /\n&trajectory\n dt_out = " + value + "\n")
    assert r.returncode == 1, r.stdout
    assert "in.nml:3" in r.stderr and "'dt_out'" in r.stderr and "not a real number" in r.stderr
    assert "Fortran's form" in r.stderr


@pytest.mark.parametrize("value, read", [("0.0625/", 0.0625), ("+.5/", 0.5), ("5./", 5.0), ("1.5d-1/", 0.15),
                                         ("2E-2 /", 0.02)])
def test_fortran_reals_still_read(tmp_path, value, read):
    r = check(tmp_path, "&run scenes = 'trajectory' /\n&trajectory\n dt_out = " + value + "\n")
    assert r.returncode == 0, r.stderr
    line = [x for x in r.stdout.splitlines() if x.strip().startswith("DT_OUT=")][0]
    assert float(line.split("=")[1].strip().rstrip(",")) == pytest.approx(read, rel=1e-15)


@pytest.mark.parametrize("group", ["equilibria", "orbits"])
def test_a_saddle_name_longer_than_its_buffer_is_refused(tmp_path, group):
    # "saddle = 'S12     junk'" was read as S12 (an 8-character buffer; the check allowed 31)
    r = check(tmp_path, f"&run scenes = 'equilibria' /\n&{group}\n saddle = 'S12     junk' /\n")
    assert r.returncode == 1
    assert "in.nml:3" in r.stderr and "'saddle' is 12 characters long: at most 7" in r.stderr
    assert check(tmp_path, f"&run scenes = 'equilibria' /\n&{group} saddle = 'S12' /\n").returncode == 0


def test_an_input_file_larger_than_the_limit_is_refused(tmp_path):
    # "--check /dev/zero" grew its buffer without limit and ended with an empty message
    r = subprocess.run([str(TUBES), "--check", "/dev/zero"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 1 and "'/dev/zero' is larger than 1048576 bytes" in r.stderr
    big = tmp_path / "big.nml"
    big.write_text("&run scenes = 'equilibria' /\n" + ("! a comment line of padding\n" * 40000))
    r = run_tubes(["--check", "big.nml"], tmp_path)
    assert r.returncode == 1 and "larger than 1048576 bytes" in r.stderr


@pytest.mark.parametrize("group, text, words", [
    ("sections", "n_seeds = 100000, n_iter = 1000000", ["n_seeds x n_iter", "1.6e+03 GB", "lower n_seeds or n_iter"]),
    ("sections", "n_seeds = 46341, n_iter = 46341", ["n_seeds x n_iter", "34.4 GB"]),
    ("experiment", "n_tracks = 50000, duration = 10, camera_rate = 50",
     ["n_tracks x duration x camera_rate", "2.71 GB"]),
])
def test_work_larger_than_the_memory_is_refused_by_check(tmp_path, group, text, words):
    # the first two passed --check, then segfaulted (malloc of 1.6 TB returned NULL) with the temp file left
    scene = "synthetic_experiment" if group == "experiment" else group
    limit = 2 << 30
    r = check(tmp_path, f"&run scenes = '{scene}' /\n&{group} {text} /\n", limit_as=limit)
    assert r.returncode == 1, r.stdout
    assert f"in.nml:2: &{group}" in r.stderr and "this machine has 2.15 GB" in r.stderr
    for w in words:
        assert w in r.stderr
    # the same run within the memory passes the check
    assert check(tmp_path, f"&run scenes = '{scene}' /\n&{group} {text} /\n").returncode in (0, 1)
    small = check(tmp_path, "&run scenes = 'sections' /\n&sections n_seeds = 1000, n_iter = 1000 /\n",
                  limit_as=limit)
    assert small.returncode == 0, small.stderr


THREE_DOF = (ROOT / "input" / "three_dof.nml").read_text()


def test_the_3dof_flux_at_a_tiny_energy_has_no_nan_column(tmp_path):
    # dE = 1e-300: the flux 0 +- 0, flux/lead and diff/sd printed as -nan, exit 0
    text = THREE_DOF.replace("'equilibria', 'orbits', 'flux'", "'equilibria', 'flux'").replace(
        "&flux de = 0.05, 0.1, order = 8, n_samples = 20000, seed = 3, n_cut = 16",
        "&flux de = 1e-300, 0.05, n_samples = 2000, seed = 3")
    (tmp_path / "f.nml").write_text(text)
    r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path)
    assert r.returncode == 2
    assert "dE = 1e-300 is too small" in r.stderr and "raise dE" in r.stderr
    assert "nan" not in r.stdout.lower()
    with h5py.File(tmp_path / "f.h5") as f:
        flux = f["/flux/flux_sampled"][()]
        assert np.isnan(f["/flux/section/p_trans_theory"][0])
        assert np.isnan(flux[0]) and flux[1] > 0


def test_the_3dof_fraction_does_not_take_a_normal_form_beyond_its_reach(tmp_path):
    # dE = 5, order 4: the normal form's change from order 2 (22.7) exceeds 10 % of its flux (158):
    # flux / volume takes the sampled flux, and agrees with the Monte Carlo
    text = THREE_DOF.replace("de = 0.05, 0.1, order = 8", "de = 5, order = 4").replace("n_cut = 16", "n_cut = 0")
    (tmp_path / "f.nml").write_text(text)
    r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "(dE = 5: flux / volume from the sampled flux" in r.stdout
    row = [x for x in r.stdout.splitlines() if x.strip().startswith("5 ")][-1]   # the fraction table's row
    frac, mc, se = float(row.split()[3]), float(row.split()[4]), float(row.split()[5])
    assert abs(frac - mc) < 5 * max(se, 1e-3)


def test_the_3dof_flux_refuses_a_shell_larger_than_its_window(tmp_path):
    # dE = 1e6 (order 4): flux / volume = 4.48 against a Monte Carlo of 1.0, exit 0; then, with the
    # normal form kept to its reach, a volume and a flux cut by the &equilibria box (they changed
    # with it: 4.02e8 at box 1.0, 5.79e8 at 1.2). At dE = 8 the shell reaches q2 = 3.1 > 2.4 (box 1.2)
    for de in ("1e6", "8"):
        text = THREE_DOF.replace("de = 0.05, 0.1, order = 8", f"de = {de}, order = 4").replace("n_cut = 16", "n_cut = 0")
        (tmp_path / "f.nml").write_text(text)
        r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path)
        assert r.returncode == 2, r.stderr
        assert "in no bounded region within its search window" in r.stderr and "(status -15)" in r.stderr
        assert " 4.482" not in r.stdout
        with h5py.File(tmp_path / "f.h5") as f:
            assert np.isnan(f["/flux/flux_sampled"][0]) and np.isnan(f["/flux/section/p_trans_theory"][0])


def test_a_trajectory_cut_short_by_max_crossings_says_so(tmp_path):
    # t_end = 200000, section = 'theta' stopped at t = 24,488 s on max_crossings, exit 0, nothing said
    (tmp_path / "t.nml").write_text("&run scenes = 'trajectory', output = 't.h5' /\n"
                                    "&trajectory t_end = 2000, section = 'theta', max_crossings = 20 /\n")
    r = run_tubes(["t.nml"], tmp_path)
    assert r.returncode == 4
    assert "before t_end = 2000 s" in r.stderr and "max_crossings" in r.stderr
    with h5py.File(tmp_path / "t.h5") as f:
        g = f["trajectory"]
        assert g.attrs["status"] == 2 and len(g["crossings/t"]) == 20 and g["t"][-1] < 2000
    # the same in Python: a RuntimeWarning and status 2; room for every crossing: status 0, t_end reached
    import tubes
    with pytest.warns(RuntimeWarning, match="before t_end = 2000"):
        out = tubes.integrate([4.0, 12.614863819914357, 0, 0], 2000.0, 1.0, section="theta", level=45.0,
                              max_crossings=20)
    assert out["status"] == tubes.FULL == 2 and len(out["crossings"]["t"]) == 20
    out = tubes.integrate([4.0, 12.614863819914357, 0, 0], 50.0, 1.0, section="theta", level=45.0,
                          max_crossings=1000)
    assert out["status"] == 0 and out["t"][-1] == 50.0


def test_a_long_ensemble_reports_its_progress(tmp_path):
    # a Monte Carlo printed nothing between "integrating N points..." and its result
    import re
    (tmp_path / "m.nml").write_text("&run scenes = 'montecarlo', output = 'm.h5' /\n&montecarlo n_samples = 200000 /\n")
    r = run_tubes(["m.nml"], tmp_path, threads=1)
    assert r.returncode == 0, r.stderr
    lines = re.findall(r"^  (\d+) of 200000 points \((\d+)%\), ([\d.]+) s, about (\d+) s left$", r.stderr, re.M)
    assert lines, r.stderr
    done = [int(x[0]) for x in lines]
    assert done == sorted(done) and all(0 < d < 200000 for d in done)
    assert all(float(x[2]) >= 1.0 for x in lines)      # none before the loop has run a second
    # Python is silent
    code = "import tubes; tubes.Model().monte_carlo(100.0, n_samples=100000)"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert p.returncode == 0 and "points (" not in p.stderr
