"""The tubes executable: options, bad input paths (message, exit code, no output file),
numerical failure, and the HDF5 contract of docs/output.md."""
import math
import os
import pathlib
import platform
import re
import subprocess
import textwrap

import h5py
import numpy as np
import pytest

from conftest import ROOT, TUBES, run_tubes

BAD = [  # (name, namelist text, substrings the message must contain)
    ("unknown group", "&runn scenes='equilibria' /\n", ["bad.nml:1", "unknown namelist group &runn", "&model"]),
    ("unknown variable", "&model\n  alpha = 0.07\n  alfa = 1 /\n", ["bad.nml:3", "&model", "'alfa'", "alpha, beta"]),
    ("malformed real", "&integrator\n rtol = abc\n/\n", ["bad.nml:2", "rtol", "abc", "not a real number"]),
    ("malformed real 2", "&integrator rtol = 1.0.3 /\n", ["bad.nml:1", "rtol", "1.0.3"]),
    ("malformed integer", "&equilibria n_grid = 4.5 /\n", ["bad.nml:1", "n_grid", "not an integer"]),
    ("malformed logical", "&trajectory at_rest = yes /\n", ["bad.nml:1", "at_rest", "logical"]),
    ("unquoted string", "&integrator method = dop853 /\n", ["bad.nml:1", "method", "quoted"]),
    ("unterminated string", "&run output = 'x.h5 /\n", ["bad.nml:1", "unterminated string"]),
    ("unclosed group", "&model alpha = 0.07\n&run /\n", ["bad.nml:2", "&model (line 1)", "not closed"]),
    ("unclosed at eof", "&model alpha = 0.07\n", ["bad.nml:1", "not closed"]),
    ("duplicate group", "&model /\n&model /\n", ["bad.nml:2", "appears twice"]),
    ("duplicate variable", "&model g = 981\n g = 980 /\n", ["bad.nml:2", "set twice"]),
    ("text outside", "alpha = 1\n", ["bad.nml:1", "outside a namelist group"]),
    ("g <= 0", "&model\n g = -9.81 /\n", ["bad.nml:2", "&model", "g = -9.81", "> 0"]),
    ("gamma <= 0", "&model gamma = 0 /\n", ["bad.nml:1", "gamma", "> 0"]),
    ("alpha <= 0", "&model alpha = -1 /\n", ["bad.nml:1", "alpha"]),
    ("damping >= 1", "&model damping_ratio = 1.5 /\n", ["bad.nml:1", "damping_ratio"]),
    ("rtol <= 0", "&integrator rtol = 0 /\n", ["bad.nml:1", "rtol", "out of range"]),
    ("atol <= 0", "&integrator atol = -1e-9 /\n", ["bad.nml:1", "atol"]),
    ("h < 0", "&integrator h = -0.1 /\n", ["bad.nml:1", "&integrator", "h = -0.1"]),
    ("max_steps < 1", "&integrator max_steps = 0 /\n", ["bad.nml:1", "max_steps"]),
    ("unknown method", "&integrator method = 'euler' /\n", ["bad.nml:1", "method = 'euler'", "dop853"]),
    ("unknown scene", "&run scenes = 'equilibria', 'normal_form' /\n", ["bad.nml:1", "'normal_form'", "trajectory"]),
    ("empty scenes", "&run scenes = '' /\n", ["bad.nml:1", "scenes is empty"]),
    ("t_end < 0", "&trajectory t_end = -1 /\n", ["bad.nml:1", "t_end", ">= 0"]),
    ("dt_out <= 0", "&trajectory dt_out = 0 /\n", ["bad.nml:1", "dt_out"]),
    ("n_grid < 2", "&equilibria n_grid = 1 /\n", ["bad.nml:1", "n_grid"]),
    ("box <= 0", "&equilibria box = 0 /\n", ["bad.nml:1", "box"]),
    ("unknown saddle", "&equilibria saddle = 'S13' /\n", ["bad.nml:1", "saddle = 'S13'", "S12"]),
    ("scalar index", "&model g(2) = 1 /\n", ["bad.nml:1", "scalar"]),
    ("too many values", "&model g = 1, 2 /\n", ["bad.nml:1", "too many values"]),
    ("no value", "&model g = /\n", ["bad.nml:1", "no value"]),
    # found by the fuzzer: the lexer stopped at a NUL byte while Fortran's READ read past it
    ("NUL byte", "&model g = 981 /\n&section kind = '\x00\x00p' /\n", ["bad.nml:2", "0x00", "not text"]),
    ("montecarlo area_tol", "&montecarlo area_tol = 1 /\n", ["bad.nml:1", "area_tol = 1", "1e-13 .. 1e-2"]),
    ("scene twice", "&run scenes = 'equilibria', 'orbits', 'equilibria' /\n", ["bad.nml:1", "'equilibria' is named twice"]),
    ("repeat count too large", "&equilibria box = 4*20.0 /\n", ["bad.nml:1", "repeat count 4", "1 to 3"]),
    ("control byte", "&model\x1b g = 981 /\n", ["bad.nml:1", "0x1b", "not text"]),
    # Tao's coupling flow turns by 2 omega h a step: at pi the method blows up (energy error 0.3 at
    # h = 0.01, omega_bind = 200, exit 0 before)
    ("tao beyond its limit", "&integrator method = 'tao2',\n h = 0.01 /\n",
     ["bad.nml:2", "2 omega_bind h = 4 is not below pi", "h < 0.00785"]),
    # an integer past 2^31: Fortran's READ said "Integer overflow while reading item 1", no name, no range
    ("seed past int32", "&montecarlo\n seed = 3000000000 /\n", ["bad.nml:2", "&montecarlo", "'seed'", "allowed >= 0",
                                                              "2147483647"]),
    ("n_samples past int32", "&montecarlo n_samples = 3000000000 /\n", ["bad.nml:1", "'n_samples'", "1 .. 10000000"]),
    # a gap in a list: the message printed the unset entry, "de = -1.7976931348623157e+308"
    ("de gap", "&run scenes = 'orbits' /\n&orbits de(1) = 1, de(3) = 10 /\n",
     ["bad.nml:2", "&orbits: de(2) is not set but de(3) is", "gap"]),
    ("de null gap", "&tubes de = 10, , 30 /\n", ["bad.nml:1", "&tubes: de(2) is not set"]),
    ("de not increasing", "&sections de = 1, 5, 3 /\n", ["bad.nml:1", "de(3) = 3", "strictly increasing"]),
    # a value for a coordinate the model does not have, and a gap in scenes, were silently ignored
    ("box(3) on 2 DOF", "&equilibria box = 1.5, 1.5, -3 /\n", ["bad.nml:1", "box(3) = -3", "system 'rolling_ball' has 2"]),
    ("box(3) after a null", "&equilibria\n box = 1.5, , 4 /\n", ["bad.nml:2", "box(3) = 4", "has 2"]),
    ("box_center(3) on 2 DOF", "&equilibria box_center(3) = 2 /\n", ["bad.nml:1", "box_center(3) = 2", "has 2"]),
    ("saddle_near(3) on 2 DOF", "&model system = 'henon_heiles' /\n&orbits saddle_near = 0, 1, 1e-3 /\n",
     ["bad.nml:2", "&orbits: saddle_near(3) = 0.001", "system 'henon_heiles' has 2"]),
    ("box(2) <= 0", "&equilibria box = 1, -1 /\n", ["bad.nml:1", "box(2) = -1", "> 0"]),
    ("scenes gap", "&run scenes(1) = 'equilibria', scenes(3) = 'orbits' /\n",
     ["bad.nml:1", "scenes(2) is empty but scenes(3) = 'orbits' follows"]),
    ("scenes null gap", "&run scenes = 'equilibria', , 'orbits' /\n", ["bad.nml:1", "scenes(2) is empty"]),
    ("n_grid past int32", "&equilibria n_grid = -3000000000 /\n", ["bad.nml:1", "'n_grid'", "2 .. 2001", "-2147483648"]),
    # the models layer (docs/models.md): systems, parameters, saddles and sections of any model
    ("unknown system", "&run scenes = 'equilibria' /\n&model system = 'nope' /\n",
     ["bad.nml:2", "system = 'nope' is not a built-in system", "henon_heiles", "cr3bp"]),
    ("parameter of another system", "&run scenes = 'equilibria' /\n&model system = 'henon_heiles', mu = 0.1 /\n",
     ["bad.nml:2", "mu is not a parameter of system 'henon_heiles'", "its parameters: damping_ratio, noise, temperature"]),
    ("cr3bp with alpha", "&run scenes = 'equilibria' /\n&model system = 'cr3bp',\n alpha = 0.1 /\n",
     ["bad.nml:3", "alpha is not a parameter of system 'cr3bp'", "its parameters: mu"]),
    ("cr3bp mu out of range", "&run scenes = 'equilibria' /\n&model system = 'cr3bp', mu = 0.9 /\n",
     ["bad.nml:2", "parameters of system 'cr3bp' are out of range", "mu = 0.9"]),
    ("de_leon_berne m_a < 0", "&run scenes = 'equilibria' /\n&model system = 'de_leon_berne', m_a = -8 /\n",
     ["parameters of system 'de_leon_berne' are out of range", "m_a = -8"]),
    ("unknown ball saddle", "&run scenes = 'orbits' /\n&orbits saddle = 'S99' /\n",
     ["saddle = 'S99' is not a rank-1 saddle of system rolling_ball", "S12, S14, S23, S34"]),
    ("unknown cr3bp saddle", "&run scenes = 'orbits' /\n&model system = 'cr3bp' /\n&orbits saddle = 'L4' /\n",
     ["saddle = 'L4' is not a rank-1 saddle of system cr3bp", "L1, L2, L3"]),
    ("saddle and saddle_near", "&run scenes = 'orbits' /\n&orbits saddle = 'S12',\n saddle_near = 1, 2 /\n",
     ["bad.nml:3", "saddle and saddle_near are both set"]),
    # dop853 with h > 0 is fixed-step: tolerances set too were silently not used
    ("dop853 fixed step with rtol", "&integrator method = 'dop853', h = 1.0,\n rtol = 1e-12 /\n",
     ["bad.nml:1", "method = 'dop853' with h = 1 takes fixed steps of h without error control", "rtol or atol"]),
    # refused only after the flux was sampled (exit 1 after the numbers)
    ("flux order on a built-in", "&run scenes = 'flux' /\n&model system = 'cr3bp', spatial = .true. /\n"
     "&flux de = 0.001, order = 6 /\n",
     ["bad.nml:3", "&flux: order = 6: the normal form needs the model written as a formula", "'cr3bp' is built in"]),
    # the nearest saddle in the box was taken however far: Henon-Heiles' S at (0.87, -0.5) for (0, 1)
    ("saddle_near outside the box", "&model system = 'henon_heiles' /\n&equilibria box = 0.9 /\n"
     "&orbits saddle_near = 0, 1, de = 0.01 /\n",
     ["bad.nml:3", "saddle_near = (0, 1) lies outside the &equilibria box", "coordinate 2 is 1",
      "half-width is 0.9", "allowed: within the box"]),
    ("plane index past ndof", "&run scenes = 'tubes' /\n&model system = 'henon_heiles' /\n"
     "&section kind = 'plane', index = 3, value = 0, direction = 1 /\n",
     ["bad.nml:3", "index = 3 is out of range: allowed 1 .. 2", "henon_heiles"]),
    ("ray on henon_heiles", "&run scenes = 'tubes' /\n&model system = 'henon_heiles' /\n&section kind = 'ray' /\n",
     ["bad.nml:3", "kind = 'ray' is the four-well ball's polar section", "kind = 'plane'"]),
    ("plane direction 0", "&run scenes = 'tubes' /\n&model system = 'henon_heiles' /\n&section direction = 0 /\n",
     ["bad.nml:3", "direction = 0 is out of range", "-1, 1"]),
    ("cr3bp without a section", "&run scenes = 'tubes' /\n&model system = 'cr3bp' /\n",
     ["system 'cr3bp' has no default section", "kind = 'plane'"]),
    ("plane with angle", "&run scenes = 'tubes' /\n&section kind = 'plane', angle = 30 /\n",
     ["angle and p_theta_sign belong to kind = 'ray'"]),
    ("unknown section kind", "&run scenes = 'tubes' /\n&section kind = 'cone' /\n",
     ["kind = 'cone' is not allowed", "ray, plane"]),
    ("experiment on henon_heiles", "&run scenes = 'synthetic_experiment' /\n&model system = 'henon_heiles' /\n",
     ["bad.nml:1", "synthetic_experiment", "system = 'rolling_ball'"]),
    ("at_rest on cr3bp", "&run scenes = 'trajectory' /\n&model system = 'cr3bp' /\n",
     ["at_rest = .true. (the default) needs a natural system", "p = (-y0, x0)"]),
    # &experiment (the synthetic_experiment scene)
    ("de_min > de_max", "&experiment de_min = 3000, de_max = 1000 /\n", ["bad.nml:1", "de_min", "de_max"]),
    ("n_tracks < 1", "&experiment n_tracks = 0 /\n", ["bad.nml:1", "n_tracks"]),
    ("duration <= 0", "&experiment duration = 0 /\n", ["bad.nml:1", "duration"]),
    ("camera_rate <= 0", "&experiment camera_rate = -50 /\n", ["bad.nml:1", "camera_rate"]),
    ("too many frames", "&experiment camera_rate = 1e6 /\n", ["bad.nml:1", "camera_rate", "1e6"]),
    ("pixel < 0", "&experiment pixel = -0.1 /\n", ["bad.nml:1", "pixel"]),
    ("noise < 0", "&experiment noise = -1 /\n", ["bad.nml:1", "noise"]),
    ("experiment damping >= 1", "&experiment damping_ratio = 1 /\n", ["bad.nml:1", "damping_ratio"]),
    ("seed < 0", "&experiment seed = -3 /\n", ["bad.nml:1", "seed"]),
    ("experiment unknown variable", "&experiment fps = 50 /\n", ["bad.nml:1", "'fps'", "camera_rate"]),
]


def _no_outputs(d: pathlib.Path):
    left = [p.name for p in d.iterdir() if p.suffix == ".h5" or ".tmp" in p.name]
    assert not left, f"output left behind: {left}"


@pytest.mark.parametrize("name,text,needles", BAD, ids=[b[0] for b in BAD])
def test_bad_input(tmp_path, tubes_exe, name, text, needles):
    (tmp_path / "bad.nml").write_text(text)
    r = run_tubes(["bad.nml", "-o", "out.h5"], tmp_path)
    assert r.returncode == 1, (r.returncode, r.stdout, r.stderr)
    for n in needles:
        assert n in r.stderr, f"{n!r} not in message: {r.stderr!r}"
    _no_outputs(tmp_path)


def test_missing_file(tmp_path, tubes_exe):
    r = run_tubes(["nope.nml"], tmp_path)
    assert r.returncode == 1
    assert "nope.nml" in r.stderr and "cannot open" in r.stderr
    _no_outputs(tmp_path)


def test_unreadable_file(tmp_path, tubes_exe):
    (tmp_path / "dir.nml").mkdir()        # a directory opens but cannot be read (even as root)
    r = run_tubes(["dir.nml"], tmp_path)
    assert r.returncode == 1
    assert "dir.nml" in r.stderr and "cannot read" in r.stderr
    _no_outputs(tmp_path)


def test_usage_errors(tmp_path, tubes_exe):
    assert run_tubes([], tmp_path).returncode == 1
    r = run_tubes(["--frobnicate", "x.nml"], tmp_path)
    assert r.returncode == 1 and "unknown option" in r.stderr
    r = run_tubes(["a.nml", "b.nml"], tmp_path)
    assert r.returncode == 1 and "only one input file" in r.stderr
    r = run_tubes(["x.nml", "-o"], tmp_path)
    assert r.returncode == 1 and "-o needs" in r.stderr


def test_unwritable_output(tmp_path, tubes_exe):
    (tmp_path / "ok.nml").write_text("")
    r = run_tubes(["ok.nml", "-o", "no/such/dir/out.h5"], tmp_path)
    assert r.returncode == 3 and "cannot create output file" in r.stderr


def test_help_and_version(tmp_path, tubes_exe):
    r = run_tubes(["--help"], tmp_path)
    assert r.returncode == 0
    for word in ["equilibria", "trajectory", "&model", "damping_ratio", "-o FILE", "--check"]:
        assert word in r.stdout
    r = run_tubes(["--version"], tmp_path)
    assert r.returncode == 0 and r.stdout.startswith("tubes ")


def test_check_only(tmp_path, tubes_exe):
    r = run_tubes(["--check", str(ROOT / "input" / "paper.nml")], tmp_path)
    assert r.returncode == 0 and "valid" in r.stdout and "&MODEL" in r.stdout
    _no_outputs(tmp_path)


def test_bad_lanes_width_refused(tmp_path, tubes_exe):
    """An invalid TUBES_LANES (the Taylor method's lanes' width) stops the run before anything runs,
    with the variable, its value and what is allowed named."""
    for bad in ("3", "16", "four"):
        env = dict(os.environ, OMP_NUM_THREADS="1", TUBES_LANES=bad)
        r = subprocess.run([str(TUBES), "--check", str(ROOT / "input" / "paper.nml")], cwd=tmp_path,
                           capture_output=True, text=True, timeout=120, env=env)
        assert r.returncode == 1, (bad, r.returncode, r.stderr)
        assert f"TUBES_LANES='{bad}'" in r.stderr and "1, 2, 4 or 8" in r.stderr, r.stderr
    _no_outputs(tmp_path)


def test_bad_lanes_driver_refused(tmp_path, tubes_exe):
    """An unknown TUBES_LANES_DRIVER (the build of the lanes' driver) stops the run before anything
    runs, naming the builds allowed; a build this processor runs is taken and recorded in the
    output's provenance (taylor_lanes_driver)."""
    env = dict(os.environ, OMP_NUM_THREADS="1", TUBES_LANES_DRIVER="avx9")
    r = subprocess.run([str(TUBES), "--check", str(ROOT / "input" / "paper.nml")], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 1, (r.returncode, r.stderr)
    assert "TUBES_LANES_DRIVER='avx9'" in r.stderr and "x86-64-v3" in r.stderr, r.stderr
    _no_outputs(tmp_path)
    (tmp_path / "e.nml").write_text("&run scenes = 'equilibria', output = 'e.h5' /\n")
    env["TUBES_LANES_DRIVER"] = "x86-64"                 # the build every x86-64 processor runs
    r = subprocess.run([str(TUBES), "e.nml"], cwd=tmp_path, capture_output=True, text=True, timeout=120, env=env)
    if platform.machine() == "x86_64":
        assert r.returncode == 0, r.stderr
        with h5py.File(tmp_path / "e.h5") as f:
            assert f.attrs["taylor_lanes_driver"] in (b"x86-64", "x86-64")


def test_empty_namelist_is_the_paper(tmp_path, tubes_exe):
    """An empty file runs with the paper's parameters: E_e and T_po as in the paper's model."""
    (tmp_path / "empty.nml").write_text("")
    r = run_tubes(["empty.nml", "-o", "e.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "e.h5") as f:
        m = f["model"].attrs
        assert (m["alpha"], m["beta"], m["gamma"], m["xi"], m["h0"], m["g"]) == \
            (0.07, 1.017, 15.103, 0.00656, 12.065, 981.0)
        assert f["saddle"].attrs["name"] == "S12"
    assert "S12" in r.stdout and "T_po" in r.stdout


def test_output_override_and_no_temp(paper_h5):
    h5, r = paper_h5                      # input/paper.nml -o p.h5, in a directory of its own
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in h5.parent.iterdir()) == ["p.h5"]


def test_numerical_failure_is_reported(tmp_path, tubes_exe):
    (tmp_path / "f.nml").write_text(textwrap.dedent("""\
        &run scenes = 'trajectory' /
        &integrator max_steps = 5 /
        """))
    r = run_tubes(["f.nml", "-o", "f.h5"], tmp_path)
    assert r.returncode == 2
    assert "maximum number of steps" in r.stderr and "t = " in r.stderr
    with h5py.File(tmp_path / "f.h5") as f:
        assert f["trajectory"].attrs["status"] == -2
        assert f.attrs["exit_status"] == 2


def test_hdf5_contract(paper_h5):
    """Every dataset and attribute docs/output.md promises for the paper's input."""
    h5, r = paper_h5
    assert r.returncode == 0, r.stderr
    with h5py.File(h5) as f:
        for a in ["tubes_version", "git_commit", "created", "input_namelist", "compiler", "taylor_lanes"]:
            assert a in f.attrs
        assert int(f.attrs["taylor_lanes"]) in (1, 2, 4, 8)
        assert "&MODEL" in f.attrs["input_namelist"]
        for a in ["alpha", "beta", "gamma", "xi", "h0", "g", "damping_ratio"]:
            assert a in f["model"].attrs
        for d in ["x", "y", "energy", "morse_index", "name"]:
            assert f["equilibria"][d].shape == (9,)
        for a in ["name", "x", "y", "energy", "lambda", "omega", "T_po"]:
            assert a in f["saddle"].attrs
        tr = f["trajectory"]
        n = tr["t"].shape[0]
        assert tr["state"].shape == (n, 4) and tr["energy"].shape == (n,)
        for a in ["method", "rtol", "atol", "nfev", "nsteps", "wall_seconds"]:
            assert a in tr.attrs
        # samples on the dt_out grid, first sample is the initial state at rest
        assert np.allclose(np.diff(tr["t"][:]), 0.02, rtol=0, atol=1e-12)
        assert np.array_equal(tr["state"][0], [4.0, 12.614863819914357, 0.0, 0.0])


def test_damped_run(tmp_path, tubes_exe):
    """zeta > 0: energy decreases monotonically along the samples (dE/dt = -2 c T <= 0)."""
    (tmp_path / "d.nml").write_text("&run scenes='trajectory' /\n&model damping_ratio=0.025 /\n"
                                    "&trajectory t_end=5 /\n")
    r = run_tubes(["d.nml", "-o", "d.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    with h5py.File(tmp_path / "d.h5") as f:
        e = f["trajectory/energy"][:]
        c = f["trajectory"].attrs["damping_rate"]
        assert f["model"].attrs["damping_rate"] == c > 0
    assert np.all(np.diff(e) <= 1e-9 * e[0])     # roundoff of the energy evaluation only
    assert e[-1] < e[0] - 100                      # loses a visible amount in 5 s


def test_docs_cover_every_variable_and_dataset(tmp_path, tubes_exe):
    """Every namelist variable of --help is in docs/input.md; every HDF5 object of a run with
    all scenes is in docs/output.md."""
    r = run_tubes(["--help"], tmp_path)
    doc = (ROOT / "docs" / "input.md").read_text()
    names = [ln.split()[0] for ln in r.stdout.splitlines() if ln.startswith("    ") and ln.split()]
    assert len(names) >= 20
    for n in names:
        assert f"`{n}`" in doc, f"namelist variable {n} missing from docs/input.md"
    (tmp_path / "all.nml").write_text("&run scenes = 'equilibria', 'trajectory', 'orbits', 'tubes', "
                                      "'transition', 'montecarlo', 'sections' /\n"
                                      "&trajectory t_end = 3, section = 'U1' /\n&orbits de = 1, 800 /\n"
                                      "&tubes de = 10, kind = 'both', area_tol = 1e-6 /\n&transition de = 10 /\n"
                                      "&montecarlo n_samples = 50 /\n&sections de = 100, n_seeds = 2, n_iter = 3 /\n")
    assert run_tubes(["all.nml", "-o", "a.h5"], tmp_path).returncode == 4   # 800: past the end
    out = (ROOT / "docs" / "output.md").read_text()
    seen = []
    with h5py.File(tmp_path / "a.h5") as f:
        f.visit(seen.append)
        for obj in [f] + [f[k] for k in seen]:
            seen += list(obj.attrs)
    # and a damped model's (docs/dissipation.md)
    (tmp_path / "damped.nml").write_text("&run scenes = 'equilibria', 'orbits', 'tubes', 'transition', "
                                         "'montecarlo', 'sections' /\n&model damping_ratio = 0.025 /\n"
                                         "&orbits de = 100 /\n&tubes de = 50, 100, area_tol = 1e-6 /\n"
                                         "&transition de = 50, 100 /\n&montecarlo n_samples = 50 /\n"
                                         "&sections de = 100, n_seeds = 2, n_iter = 3 /\n")
    assert run_tubes(["damped.nml", "-o", "d.h5"], tmp_path).returncode == 0
    with h5py.File(tmp_path / "d.h5") as f:
        more = []
        f.visit(more.append)
        for obj in [f] + [f[k] for k in more]:
            seen += list(obj.attrs) + [obj.name]
    import re
    for name in set(re.sub(r"_\d{3}$", "_<kkk>", s.split("/")[-1]) for s in seen) - {"units", ""}:
        assert f"`{name}`" in out or f"`/{name}`" in out, f"HDF5 object {name} missing from docs/output.md"


def test_messages_echo_the_value_as_written_and_do_not_contradict(tmp_path):
    (tmp_path / "r.nml").write_text("&run scenes = 'equilibria' /\n&integrator rtol = 1e-16 /\n")
    r = run_tubes(["r.nml"], tmp_path)
    assert r.returncode == 1 and "rtol = 1e-16 is out of range" in r.stderr, r.stderr
    (tmp_path / "r.nml").write_text("&run scenes = 'trajectory' /\n&integrator method = 'rk4' /\n")
    r = run_tubes(["r.nml"], tmp_path)
    assert r.returncode == 1 and "method = 'rk4' is fixed-step: it needs h > 0" in r.stderr, r.stderr
    assert "allowed >= 0" not in r.stderr
    (tmp_path / "r.nml").write_text("&model system = 'coupled_quartic' /\n&run scenes = 'equilibria' /\n")
    r = run_tubes(["r.nml", "-o", "r.h5"], tmp_path)
    assert r.returncode == 0 and "-0.0000" not in r.stdout, r.stdout


def test_an_output_that_is_a_directory_is_refused_before_the_work(tmp_path):
    (tmp_path / "d.nml").write_text("&run scenes = 'equilibria', 'orbits' /\n")
    (tmp_path / "adir").mkdir()
    r = run_tubes(["d.nml", "-o", "adir"], tmp_path)
    assert r.returncode == 3 and "'adir' is a directory" in r.stderr, r.stderr
    assert r.stdout == ""                          # nothing was computed
    assert not list(tmp_path.glob("adir.tmp*")) and not list((tmp_path / "adir").iterdir())


def test_an_output_that_is_not_a_regular_file_or_is_the_input_is_refused(tmp_path):
    """The finished file is renamed over whatever has the output's name: a FIFO, a device or the
    input file would be replaced by it. Refused before the work; a link is written through."""
    (tmp_path / "d.nml").write_text("&run scenes = 'equilibria' /\n")
    os.mkfifo(tmp_path / "fifo")
    for out, code, words in [("fifo", 3, "'fifo' is a FIFO"), ("/dev/null", 3, "'/dev/null' is a device"),
                             ("d.nml", 1, "is the input file 'd.nml'"),
                             ("../" + tmp_path.name + "/d.nml", 1, "is the input file")]:
        r = run_tubes(["d.nml", "-o", out], tmp_path)
        assert r.returncode == code and words in r.stderr, (out, r.stderr)
        assert r.stdout == ""                      # nothing was computed
    assert (tmp_path / "fifo").is_fifo() and (tmp_path / "d.nml").read_text().startswith("&run")
    assert pathlib.Path("/dev/null").is_char_device()
    (tmp_path / "target.h5").write_bytes(b"")
    (tmp_path / "link.h5").symlink_to(tmp_path / "target.h5")
    r = run_tubes(["d.nml", "-o", "link.h5"], tmp_path)
    assert r.returncode == 0 and (tmp_path / "link.h5").is_symlink(), r.stderr
    assert h5py.is_hdf5(tmp_path / "target.h5")
    # a link whose target's path is longer than the output name can hold (1023 characters): named
    # so, not "a symbolic link to nothing"
    deep = tmp_path
    for k in range(5):
        deep = deep / (f"{k}" * 240)
    deep.mkdir(parents=True)
    (deep / "far.h5").write_bytes(b"")
    (tmp_path / "far.h5").symlink_to(deep / "far.h5")
    r = run_tubes(["d.nml", "-o", "far.h5"], tmp_path)
    assert r.returncode == 3 and "whose path is longer than 1023 characters" in r.stderr, r.stderr
    assert r.stdout == "" and (deep / "far.h5").read_bytes() == b""


@pytest.mark.parametrize("csv,words", [("e.h5", "is the HDF5 output file"), ("x.nml", "is the input file"),
                                       ("nodir/t.csv", "its directory does not exist"),
                                       ("/dev/null", "is not a regular file")])
def test_a_csv_that_would_clobber_a_file_is_refused_before_the_work(tmp_path, csv, words):
    (tmp_path / "x.nml").write_text("&run scenes = 'synthetic_experiment', output = 'e.h5' /\n"
                                    f"&experiment n_tracks = 2,\n csv = '{csv}' /\n")
    r = run_tubes(["x.nml"], tmp_path)
    assert r.returncode == 1 and f"x.nml:3: &experiment csv = '{csv}'" in r.stderr and words in r.stderr, r.stderr
    assert r.stdout == "" and (tmp_path / "x.nml").read_text().startswith("&run")
    _no_outputs(tmp_path)


@pytest.mark.parametrize("sig,code,word", [(2, 130, "SIGINT"), (15, 143, "SIGTERM")])
def test_a_signal_stops_the_run_and_leaves_no_file(tmp_path, sig, code, word):
    import signal
    import time
    (tmp_path / "s.nml").write_text("&run scenes = 'sections', output = 's.h5' /\n"
                                    "&sections de = 100, 500, n_seeds = 40, n_iter = 5000 /\n")
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.Popen([str(TUBES), "s.nml"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while not list(tmp_path.glob("s.h5.tmp*")) and time.time() - t0 < 30:   # the run has started
        time.sleep(0.05)
    time.sleep(0.3)
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    assert p.returncode == code, err
    assert f"stopped by {word}" in err and "no output written" in err
    assert not list(tmp_path.glob("s.h5*"))


def test_a_full_disk_is_an_io_error_without_a_crash_or_a_file(tmp_path):
    """A 2 MB filesystem fills during the write: exit 3 with the reason, no file left, no crash
    (HDF5's exit handler used to walk the half-closed file: SIGSEGV)."""
    small = tmp_path / "small"
    small.mkdir()
    m = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(small)], capture_output=True)
    if m.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here (needs root)")
    try:
        (tmp_path / "f.nml").write_text("&run scenes = 'synthetic_experiment' /\n"
                                        "&experiment n_tracks = 60, duration = 20.0 /\n")
        r = run_tubes(["f.nml", "-o", str(small / "full.h5")], tmp_path)
        assert r.returncode == 3, (r.returncode, r.stderr)
        assert "No space left on device" in r.stderr and "no output file was left" in r.stderr
        assert list(small.iterdir()) == []
    finally:
        subprocess.run(["umount", str(small)], capture_output=True)


@pytest.mark.parametrize("text", [
    "",
    "&run scenes = 'orbits' /\n&orbits saddle_near = 1, 1 /\n",
    "&run scenes = 'orbits', 'tubes' /\n&model system = 'henon_heiles' /\n&orbits de = 0.01 /\n&tubes de = 0.01 /\n",
    "&section kind = 'ray', angle = 225, p_theta_sign = 1 /\n",
    "&run scenes = 1*'orbits', 'equilibria' /\n",
    "&equilibria box = 2*15.0, box_center = 2*, 0.0 /\n",
], ids=["defaults", "saddle_near", "henon_heiles", "ray", "repeated string", "repeat and nulls"])
def test_the_effective_namelist_reads_back_to_itself(tmp_path, tubes_exe, text):
    """What --check prints (and every output file stores as input_namelist) is an input file that
    gives the same run: the fuzzer found it refused ('saddle and saddle_near are both set')."""
    (tmp_path / "a.nml").write_text(text)
    r = run_tubes(["--check", "a.nml"], tmp_path)
    assert r.returncode == 0, r.stderr
    eff = r.stdout.split("\n", 1)[1]
    (tmp_path / "b.nml").write_text(eff)
    r2 = run_tubes(["--check", "b.nml"], tmp_path)
    assert r2.returncode == 0, r2.stderr
    assert r2.stdout.split("\n", 1)[1] == eff


def test_a_read_only_directory_is_refused_before_the_work(tmp_path, tubes_exe):
    """Exit 3 naming the reason, before any computing, nothing left behind. Root writes through
    file modes, so as root the directory is a read-only tmpfs."""
    ro = tmp_path / "ro"
    ro.mkdir()
    mounted = False
    if os.geteuid() == 0:
        m = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1m", "tmpfs", str(ro)], capture_output=True)
        if m.returncode != 0:
            pytest.skip("cannot mount a read-only tmpfs here")
        mounted = True
    else:
        ro.chmod(0o555)
    try:
        (tmp_path / "p.nml").write_text("&run scenes = 'montecarlo' /\n&montecarlo n_samples = 2000000 /\n")
        r = run_tubes(["p.nml", "-o", str(ro / "out.h5")], tmp_path, timeout=60)
        assert r.returncode == 3, (r.returncode, r.stderr)
        assert "Read-only file system" in r.stderr or "Permission denied" in r.stderr, r.stderr
        assert str(ro / "out.h5") in r.stderr
        assert list(ro.iterdir()) == []
    finally:
        if mounted:
            subprocess.run(["umount", str(ro)], capture_output=True)
        else:
            ro.chmod(0o755)


def _nml_values(text):
    """The values of a namelist item as written by --check or in the docs: repeats (3*0) expanded,
    strings unquoted and stripped, logicals as bool, numbers as float."""
    import re
    out = []
    for rep, rval, quoted, plain in re.findall(r"(\d+)\*([^,\s]+)|('[^']*')|([^,\s]+)", text):
        for v in [rval] * int(rep) if rep else [quoted or plain]:
            v = v.strip()
            if v.startswith("'"):
                out.append(v.strip("'").strip())
            elif v.upper() in ("T", ".TRUE."):
                out.append(True)
            elif v.upper() in ("F", ".FALSE."):
                out.append(False)
            else:
                try:
                    out.append(float(v.replace("D", "E").replace("d", "e")))
                except ValueError:
                    out.append(v)
    return out


def test_documented_defaults_are_the_defaults(tmp_path, tubes_exe):
    """The defaults --help and docs/input.md state (two texts beside the reader's own values in
    src/io/tubes_nml.f90) are the values --check prints for a namelist that sets nothing: every
    plain one (numbers, lists, strings, logicals; not "the system's ...")."""
    import re
    (tmp_path / "empty.nml").write_text("&run /\n")
    r = run_tubes(["--check", "empty.nml"], tmp_path)
    assert r.returncode == 0, r.stderr
    effective = {}
    for g, body in re.findall(r"&(\w+)\s*(.*?)\n\s*/", r.stdout.split("\n", 1)[1], re.S):
        items = re.findall(r"(\w+)\s*=\s*(.*?)(?=,?\s*\w+\s*=|,?\s*$)", body.replace("\n", " "), re.S)
        effective[g.lower()] = {k.lower(): _nml_values(v.strip().rstrip(",")) for k, v in items}
    stated = []       # (where, group, variable, default text)
    group = None
    for ln in run_tubes(["--help"], tmp_path).stdout.splitlines():
        m = re.match(r"  &(\w+)$", ln)
        group = m.group(1) if m else group
        m = re.match(r"    (\w+)\s+\w+\s+\[.*?\] default (.*?); ", ln)
        if m and group:
            stated.append(("--help", group, m.group(1), m.group(2)))
    for ln in (ROOT / "docs" / "input.md").read_text().splitlines():
        m = re.match(r"## `&(\w+)`", ln)
        group = m.group(1) if m else group
        cells = [c.strip() for c in ln.split("|")[1:-1]]
        if len(cells) >= 5 and re.fullmatch(r"`\w+`", cells[0]):
            stated.append(("docs/input.md", group, cells[0].strip("`"), cells[3]))
    compared = 0
    for where, g, var, text in stated:
        if g not in effective or var not in effective[g]:
            continue
        if re.search(r"[()]|\.\.\.|none|the |system|-$|^-|^$", text.strip("`")):
            continue          # not a plain value: a sentence, an elision, per-system defaults
        want = _nml_values(text.replace("`", ""))
        got = effective[g][var][:len(want)]
        if any(isinstance(v, str) and not re.fullmatch(r"[\w.+-]*", v) for v in want):
            continue
        compared += 1
        assert want == got, f"{where}: &{g} {var}: stated default {text!r}, the reader's {effective[g][var]}"
    assert compared >= 100, compared


@pytest.mark.parametrize("t_end,dt_out,times", [(0.3, 0.1, [0, 0.1, 0.2, 0.3]), (1.0, 2.0, [0, 1.0]),
                                                (1.0, 0.3, [0, 0.3, 0.6, 0.9, 1.0])])
def test_the_trajectory_is_sampled_at_its_end(tmp_path, t_end, dt_out, times):
    """The end is a sample whatever dt_out: 3 * 0.1 > 0.3 in floating point dropped it, and a
    dt_out beyond t_end gave the start alone ('to t = 0 s'). The end's state is the integration's
    own (a second run straight to t_end, sampled at its ends only, gives the same bits)."""
    (tmp_path / "t.nml").write_text(f"&run scenes = 'trajectory' /\n&trajectory t_end = {t_end}, dt_out = {dt_out} /\n")
    r = run_tubes(["t.nml", "-o", "t.h5"], tmp_path)
    assert r.returncode == 0 and f"to t = {t_end:g} s: {len(times)} samples" in r.stdout, r.stdout + r.stderr
    (tmp_path / "e.nml").write_text(f"&run scenes = 'trajectory' /\n&trajectory t_end = {t_end}, dt_out = {2 * t_end} /\n")
    assert run_tubes(["e.nml", "-o", "e.h5"], tmp_path).returncode == 0
    with h5py.File(tmp_path / "t.h5") as f, h5py.File(tmp_path / "e.h5") as g:
        t = f["trajectory/t"][:]
        assert np.allclose(t, times, rtol=0, atol=1e-15) and t[-1] == t_end
        assert list(g["trajectory/t"][:]) == [0, t_end]
        assert np.array_equal(f["trajectory/state"][-1], g["trajectory/state"][-1])


def test_an_unknown_scene_lists_every_scene(tmp_path, tubes_exe):
    """The scenes a refusal offers are the table's (--help's 'Scenes'): a copy of the list in the
    message had left out flux."""
    helptext = run_tubes(["--help"], tmp_path).stdout
    scenes = [ln.split()[0] for ln in helptext.split("Scenes", 1)[1].split("\n\n")[0].splitlines()[1:]]
    assert "flux" in scenes and "synthetic_experiment" in scenes, scenes
    (tmp_path / "s.nml").write_text("&run scenes = 'equilibrium' /\n")
    r = run_tubes(["s.nml"], tmp_path)
    assert r.returncode == 1 and "s.nml:1: &run: scenes = 'equilibrium' is not allowed: allowed " in r.stderr, r.stderr
    assert r.stderr.split("allowed ", 1)[1].strip() == ", ".join(scenes), r.stderr


@pytest.mark.parametrize("text", ["&run scenes = 'orbits' /\n&orbits de(1) = 1, de(3) = 10 /\n",
                                  "&transition de = -5 /\n", "&transition de = 1, 5, 3 /\n",
                                  "&montecarlo gate = -1 /\n", "&equilibria box = -1 /\n"],
                         ids=["gap", "transition de", "transition order", "montecarlo gate", "box"])
def test_one_message_per_mistake_at_its_line(tmp_path, tubes_exe, text):
    """One message per mistake, about the variable set, at a real line: a gap printed the unset
    entry (-1.797e+308); &flux de (default: the &transition list) and &flux gate (the &montecarlo
    gate) repeated &transition's and &montecarlo's message at line 0; box = -1 was refused once per
    coordinate."""
    (tmp_path / "m.nml").write_text(text)
    r = run_tubes(["m.nml"], tmp_path)
    lines = r.stderr.splitlines()
    assert r.returncode == 1 and len(lines) == 1, r.stderr
    assert lines[0].startswith("m.nml:") and not lines[0].startswith("m.nml:0:"), r.stderr
    assert "e+308" not in r.stderr and "&flux" not in r.stderr, r.stderr


def test_one_element_of_box_or_saddle_near_is_used(tmp_path, tubes_exe):
    """box(2) or saddle_near(2) alone set that coordinate (they were ignored without box(1),
    saddle_near(1)); a 0 for a coordinate the model lacks is what --check writes there: let through."""
    (tmp_path / "b.nml").write_text("&model system = 'henon_heiles' /\n&equilibria box(2) = 5, box_center = 0, 0, 0 /\n"
                                    "&orbits saddle_near(2) = -0.5 /\n")
    r = run_tubes(["--check", "b.nml"], tmp_path)
    assert r.returncode == 0, r.stderr
    eff = r.stdout.replace(" ", "")
    assert "BOX=1.5000000000000000,5.0000000000000000," in eff, r.stdout
    assert "SADDLE_NEAR=0.0000000000000000,-0.50000000000000000," in eff, r.stdout


@pytest.mark.parametrize("text,units,not_units", [
    ("&model system = 'henon_heiles' /\n&orbits de = -1 /\n", "orbits, 1);", "cm"),
    ("&model system = 'henon_heiles' /\n&montecarlo t_max = -1 /\n", "a point, 1)", " s)"),
    ("&model system = 'coupled_quartic' /\n&run scenes = 'trajectory' /\n&integrator method = 'rk4' /\n",
     "(the step [1])", "[s]"),
    ("&orbits de = -1 /\n", "orbits, (cm/s)^2);", "energy"),
    ("&flux de = -1 /\n", "flux, (cm/s)^2);", "energy"),
    ("&flux t_max = -1 /\n", "past, s)", "time"),
], ids=["henon_heiles de", "henon_heiles t_max", "coupled_quartic h", "ball de", "ball flux de", "ball flux t_max"])
def test_messages_give_the_models_units(tmp_path, tubes_exe, text, units, not_units):
    """A dimensionless model's values are in units of 1 (as its output file's units attributes):
    the dE messages said (cm/s)^2 for Henon-Heiles; the ball's are cm, s, (cm/s)^2 (&flux's table
    entries say 'energy', 'time' for any model)."""
    (tmp_path / "u.nml").write_text(text)
    r = run_tubes(["u.nml"], tmp_path)
    assert r.returncode == 1 and units in r.stderr and not_units not in r.stderr, r.stderr


@pytest.mark.parametrize("nml,words", [
    ("&model h0 = 1e8 /\n&run scenes = 'orbits' /\n&orbits de = 1 /\n", "below what the energy resolves"),
    ("&model system = 'cr3bp_spatial' /\n&run scenes = 'trajectory' /\n&trajectory at_rest = .false. /\n",
     "'trajectory' takes (x0, y0, px0, py0)"),
    ("&run scenes = 'orbits' /\n&orbits saddle = 'S99' /\n", "is not a rank-1 saddle"),
], ids=["de", "scene", "saddle"])
def test_check_refuses_what_the_run_refuses(tmp_path, nml, words):
    """--check said 'valid' for inputs the run then refused before its work (the model's checks:
    a dE the energy cannot resolve, a scene the model cannot have, a saddle it lacks): it runs the
    same checks now, with the run's message and exit code, and writes nothing."""
    (tmp_path / "a.nml").write_text(nml)
    c = run_tubes(["--check", "a.nml"], tmp_path)
    r = run_tubes(["a.nml", "-o", "a.h5"], tmp_path)
    said = [[ln for ln in x.stderr.splitlines() if words in ln] for x in (c, r)]   # (a Taylor kernel's build
    assert c.returncode == r.returncode == 1 and said[0] and said[0] == said[1], (c.stderr, r.stderr)  # may add a line)
    assert "valid" not in c.stdout and not list(tmp_path.glob("*.h5"))


@pytest.mark.parametrize("nml,head", [
    ("&model system = 'cr3bp_spatial' /\n&run scenes = 'trajectory' /\n",
     "z.nml: &trajectory: at_rest = .true. (the default)"),                  # the reader's message
    ("&model h0 = 1e8 /\n&run scenes = 'orbits' /\n", "z.nml: &orbits de = 1: below what the energy resolves"),
], ids=["reader", "setup"])                                                  # the run's set-up's
def test_a_default_has_no_line_zero(tmp_path, nml, head):
    """A message about a value the file does not set (at_rest's default in a file without
    &trajectory; &orbits de's default list) said 'z.nml:0:'; there is no line to name: 'z.nml:'."""
    (tmp_path / "z.nml").write_text(nml)
    r = run_tubes(["z.nml", "-o", "z.h5"], tmp_path)
    assert r.returncode == 1 and any(ln.startswith(head) for ln in r.stderr.splitlines()), r.stderr
    assert ":0:" not in r.stderr                         # (a Taylor kernel's first build may say a line before)


def test_a_damped_ball_on_a_formula_surface_reports_its_loss(tmp_path, tubes_exe):
    """A formula surface's damping_ratio is the model's parameter, not &model's variable of the
    built-in ball: the trajectory scene took the loss for an energy error (relative 0.9998). The
    loss is the closed form's: c = 2 zeta omega_1 at the lowest well, E0 - E(t_end) > 0."""
    (tmp_path / "d.nml").write_text(
        "&run scenes = 'trajectory' /\n"
        "&model system = 'rolling_ball', surface = 'expression', height = 'k*y^2/2 + c*(x^4/4 - a^2*x^2/2)',\n"
        " constants = 'k = 0.1', 'c = 0.002', 'a = 5', damping_ratio = 0.05 /\n"
        "&equilibria box = 10 /\n&trajectory x0 = 3, y0 = 4, t_end = 10, dt_out = 0.5 /\n")
    r = run_tubes(["d.nml", "-o", "d.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    m = re.search(r"damped \(zeta = 0.05, c = (\S+) 1/s\): energy lost (\S+)", r.stdout)
    assert m and "max energy error" not in r.stdout, r.stdout
    # the wells at x = +-5: h_xx = c (3 x^2 - a^2) = 0.1 = h_yy, omega_1^2 = (5/7) g 0.1
    assert abs(float(m.group(1)) - 2 * 0.05 * math.sqrt(5 / 7 * 981 * 0.1)) < 1e-5 and float(m.group(2)) > 0
