"""The Python layer (tubes._core through the tubes package) against independent references:
the paper's kinetic energy written out in numpy, finite-difference Hamilton equations, and
scipy integrating the rolling ball's Lagrangian (velocity) form."""
import pathlib
import shutil
import subprocess

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import tubes
from conftest import ROOT, run_tubes

M = tubes.Model()
A, B, G, XI, H0, GRAV = M.alpha, M.beta, M.gamma, M.xi, M.h0, M.g


def H(x, y):
    return A * (x * x + y * y) - B * (np.sqrt(x * x + G) + np.sqrt(y * y + G)) - XI * x * y + H0


def dH(x, y):
    sx, sy = np.sqrt(x * x + G), np.sqrt(y * y + G)
    return (2 * A * x - B * x / sx - XI * y, 2 * A * y - B * y / sy - XI * x,
            2 * A - B * G / sx**3, -XI, 2 * A - B * G / sy**3)


def energy_paper(s):
    """Eq. (kin_rescale) + g H, exactly as printed in the paper."""
    x, y, px, py = s
    hx, hy, *_ = dH(x, y)
    t = 5 / 14 * ((1 + hy**2) * px**2 + (1 + hx**2) * py**2 - 2 * hx * hy * px * py) / (1 + hx**2 + hy**2)
    return t + GRAV * H(x, y)


def lagrangian_rhs(_t, z):
    """x'' = -h Hx, y'' = -h Hy, h = (5g/7 + Hxx x'^2 + 2 Hxy x'y' + Hyy y'^2)/(1 + Hx^2 + Hy^2)."""
    x, y, vx, vy = z
    hx, hy, hxx, hxy, hyy = dH(x, y)
    h = (5 * GRAV / 7 + hxx * vx**2 + 2 * hxy * vx * vy + hyy * vy**2) / (1 + hx**2 + hy**2)
    return [vx, vy, -h * hx, -h * hy]


STATES = [np.array(s) for s in ([4.0, 12.6, 0.0, 0.0], [6.1, -0.3, 35.0, -12.0],
                                [-3.0, 7.5, -60.0, 80.0], [10.0, 10.0, 5.0, 150.0])]


@pytest.mark.parametrize("s", STATES)
def test_energy_matches_paper_formula(s):
    # two algebraically equal forms of T: agreement to roundoff of ~1e4-sized sums
    assert tubes.energy(s) == pytest.approx(energy_paper(s), rel=1e-13)


@pytest.mark.parametrize("s", STATES)
def test_vector_field_is_hamiltonian(s):
    """dq/dt = dE/dp, dp/dt = -dE/dq by central differences of the paper's energy."""
    f = tubes.vector_field(s)
    eps = 1e-5   # central difference: truncation ~ eps^2 |E'''| ~ 1e-8, roundoff ~ 1e-16 E/eps ~ 1e-8
    grad = np.array([(energy_paper(s + eps * e) - energy_paper(s - eps * e)) / (2 * eps) for e in np.eye(4)])
    expect = np.array([grad[2], grad[3], -grad[0], -grad[1]])
    assert np.allclose(f, expect, rtol=1e-7, atol=1e-6)


def test_vector_field_and_velocity_of_rows():
    """Rows of states (m, 4) in one call: each row the one-state call's value, bit for bit, and
    the central differences of the paper's energy; velocity is its first half; the columns'
    layout (4, m) is refused."""
    rows = np.array(STATES, dtype=float)
    f = tubes.vector_field(rows)
    assert f.shape == rows.shape
    assert np.array_equal(f, np.array([tubes.vector_field(s) for s in rows]))
    eps = 1e-5
    for s, fs in zip(rows, f):
        grad = np.array([(energy_paper(s + eps * e) - energy_paper(s - eps * e)) / (2 * eps) for e in np.eye(4)])
        assert np.allclose(fs, [grad[2], grad[3], -grad[0], -grad[1]], rtol=1e-7, atol=1e-6)
    assert np.array_equal(tubes.velocity(rows), f[:, :2])
    assert tubes.velocity(rows[0]).shape == (2,)
    with pytest.raises(ValueError, match="pass the transpose"):
        tubes.vector_field(rows[:3].T)


def test_rows_refused_by_name():
    """A row the model refuses (a blown-up state) is named by its index and values; momentum's q
    and v of different shapes are refused (ValueError), as is a layout of columns."""
    rows = np.array([[4.0, 12.6, 0, 0], [1.0, 1.0, 0, 0], [1e7, 0, 0, 0], [1e8, 0, 0, 0]])
    with pytest.raises(tubes.TubesError, match=r"vector_field: row 2 of 4 \(10000000, 0, 0, 0\): the model refused"):
        tubes.vector_field(rows)
    with pytest.raises(tubes.TubesError, match=r"velocity|vector_field: row 2 of 4"):
        tubes.velocity(rows)
    with pytest.raises(tubes.TubesError, match=r"^vector_field: the model refused"):
        tubes.vector_field(rows[2])                                  # one state: no row to name
    with pytest.raises(ValueError, match=r"q and v must have the same shape: got \(3, 2\) and \(2, 2\)"):
        tubes.momentum(rows[:3, :2], rows[:2, 2:])
    with pytest.raises(ValueError, match="pass the transpose"):
        tubes.momentum(rows[:3, :2].T, rows[:3, 2:].T)


def test_velocity_momentum_roundtrip():
    q, v = np.array([3.0, -2.0]), np.array([12.0, -40.0])
    p = tubes.momentum(q, v)
    hx, hy, *_ = dH(*q)
    m = np.eye(2) + np.outer([hx, hy], [hx, hy])
    assert np.allclose(p, 1.4 * m @ v, rtol=1e-14)              # p = (7/5) M v
    assert np.allclose(tubes.velocity([*q, *p]), v, rtol=1e-13)


def test_trajectory_against_lagrangian_form():
    """tubes' DOP853 on Hamilton's equations vs scipy's DOP853 on the Lagrangian form.
    Both run at tolerance 1e-12; over 1 s the difference can grow at most like
    exp(lambda t) with lambda ~ 9/s (the saddle's rate, an upper bound on the stretching
    here): 1e-12 * 1e4 * |x| -> allow 1e-7 relative to the state's scale."""
    q0 = np.array([4.0, 12.614863819914357])
    sol = solve_ivp(lagrangian_rhs, (0, 1.0), [*q0, 0, 0], method="DOP853", rtol=1e-12, atol=1e-12)
    x, y, vx, vy = sol.y[:, -1]
    p_ref = tubes.momentum([x, y], [vx, vy])
    tr = tubes.trajectory([*q0, 0, 0], 1.0, dt_out=0.5)
    got = tr["state"][-1]
    ref = np.array([x, y, *p_ref])
    scale = np.abs(ref).max()
    assert np.abs(got - ref).max() <= 1e-7 * scale, (got, ref)
    # the samples lie on the dt_out grid and conserve the paper's energy
    assert np.allclose(tr["t"], [0.0, 0.5, 1.0])
    e = [energy_paper(s) for s in tr["state"]]
    assert np.ptp(e) <= 1e-10 * e[0]      # tol 1e-12 per step, ~100 steps


def test_trajectory_errors_raise():
    with pytest.raises(tubes.TubesError) as err:
        tubes.trajectory([4.0, 12.0, 0, 0], 1.0, max_steps=3)
    assert err.value.code == tubes.EMAXSTEPS
    with pytest.raises(ValueError):
        tubes.trajectory([4.0, 12.0, 0, 0], 1.0, method="euler")
    with pytest.raises(ValueError):
        tubes.energy([1.0, 2.0, 3.0])


def test_equilibria_from_python():
    eq = tubes.equilibria()
    assert sorted(eq["name"]) == sorted(["W1", "W2", "W3", "W4", "S12", "S14", "S23", "S34", "R1"])
    sad = [i for i, n in enumerate(eq["name"]) if n.startswith("S")]
    e = eq["energy"][sad]
    assert np.ptp(e) <= 1e-12 * e[0]                          # symmetric saddles, same energy
    for i in sad:   # each saddle energy is g H there, the energy of the ball at rest
        assert tubes.energy([eq["x"][i], eq["y"][i], 0, 0]) == pytest.approx(eq["energy"][i], rel=1e-14)
        _, hy, hxx, hxy, hyy = dH(eq["x"][i], eq["y"][i])
        kmin = 0.5 * (hxx + hyy) - np.hypot(0.5 * (hxx - hyy), hxy)
        assert eq["lambda"][i] == pytest.approx(np.sqrt(-5 / 7 * GRAV * kmin), rel=1e-12)


def test_load_reads_a_run(paper_h5):
    h5, r = paper_h5
    assert r.returncode == 0, r.stderr
    res = tubes.load(str(h5))
    assert res.saddle.name == "S12" and res["saddle/name"] == "S12"
    assert res.saddle.T_po == pytest.approx(2 * np.pi / res.saddle.omega, rel=1e-15)
    assert res.equilibria.name[4] == "S12" and isinstance(res.equilibria.x, np.ndarray)
    assert res.trajectory.state.shape == (len(res.trajectory.t), 4)
    assert res.trajectory.method == "auto (taylor)"            # input/paper.nml's method
    assert "&MODEL" in res.input_namelist
    with pytest.raises(AttributeError):
        _ = res.nonexistent


# ---------------------------------------------------------------- models by name (the library)

def test_models_by_name_and_their_table():
    assert tubes.systems() == ["rolling_ball", "henon_heiles", "de_leon_berne", "coupled_quartic", "cr3bp",
                              "cr3bp_spatial"]
    m = tubes.Model()
    assert m.system == "rolling_ball" and m.alpha == 0.07 and m.ndof == 2
    assert tubes.Model(alpha=0.08).alpha == 0.08
    assert tubes.Model(system="cr3bp").mu == 0.01215058560962404
    with pytest.raises(ValueError, match="mu is not a parameter of system 'henon_heiles'"):
        tubes.Model(system="henon_heiles", mu=0.1)
    with pytest.raises(ValueError, match="unknown system 'nope'"):
        tubes.Model(system="nope")
    with pytest.raises(ValueError, match="out of range"):
        tubes.Model(system="cr3bp", mu=0.9)
    with pytest.raises(ValueError, match="out of range"):
        tubes.Model(gamma=-1.0)
    assert tubes.Model(system="de_leon_berne", m_a=4.0) == tubes.Model(system="de_leon_berne").replace(m_a=4.0)


def test_arrays_of_states_are_rows_and_other_layouts_are_refused():
    """energies, potentials, shape_derivatives and ensemble read one state (or position) per ROW:
    an array with one per column (scipy's sol.y, (2N, m)) was reshaped to rows of other numbers
    and gave wrong energies without a word; now it is refused, naming the function, the shape
    and the layout, and suggesting the transpose."""
    hh = tubes.Model(system="henon_heiles")
    s = np.linspace(-0.4, 0.4, 20).reshape(5, 4)                 # 5 states, one per row
    ref = 0.5 * (s[:, 2] ** 2 + s[:, 3] ** 2) + 0.5 * (s[:, 0] ** 2 + s[:, 1] ** 2) \
        + s[:, 0] ** 2 * s[:, 1] - s[:, 1] ** 3 / 3
    assert np.allclose(tubes.energies(s, hh), ref, rtol=1e-15, atol=1e-16)   # roundoff of O(1) sums
    assert tubes.energies(s[2], hh).shape == (1,) and tubes.energies(s[2], hh)[0] == tubes.energies(s, hh)[2]
    for call in (lambda a: tubes.energies(a, hh), lambda a: tubes.ensemble(a, 0.1, model=hh)):
        with pytest.raises(ValueError, match=r"\(m, 4\).*per row.*got shape \(4, 5\).*sol\.y\.T"):
            call(s.T)                                             # sol.y's layout
        with pytest.raises(ValueError, match=r"got shape \(2, 5, 4\)"):
            call(s[None].repeat(2, axis=0))                       # no reshaping of any other layout
    with pytest.raises(ValueError, match=r"^energies: states must have shape \(m, 4\).*got shape \(20,\)$"):
        tubes.energies(s.ravel(), hh)
    q = s[:, :2]
    v = tubes.potentials(q, hh)
    assert np.allclose(v, 0.5 * (q[:, 0] ** 2 + q[:, 1] ** 2) + q[:, 0] ** 2 * q[:, 1] - q[:, 1] ** 3 / 3,
                       rtol=1e-15, atol=1e-16)
    g, h = tubes.shape_derivatives(q, hh)
    assert g.shape == (2, 5) and h.shape == (2, 2, 5) and tubes.shape_derivatives(q[0], hh)[0].shape == (2, 1)
    for name, f in (("potentials", tubes.potentials), ("shape_derivatives", tubes.shape_derivatives)):
        with pytest.raises(ValueError, match=rf"^{name}: q must have shape \(m, 2\).*got shape \(2, 5\)"
                                             r".*q\.T \(sol\.y\[:N\]\.T\)"):
            f(q.T, hh)
    # one state: (4,) or one row, never another shape with 4 elements
    assert tubes.energy(s[0].reshape(1, 4), hh) == tubes.energy(s[0], hh)
    with pytest.raises(ValueError, match=r"state must have 4 components, one vector of shape \(4,\): got shape \(2, 2\)"):
        tubes.energy(s[0].reshape(2, 2), hh)


def test_henon_heiles_from_python_against_closed_forms():
    hh = tubes.Model(system="henon_heiles")
    # H at a state, one by one and vectorised (the same Fortran function)
    x = np.array([[0.1, 0.2, 0.3, 0.4], [-0.3, 0.1, 0.0, 0.5]])
    e = tubes.energies(x, hh)
    ref = 0.5 * (x[:, 2] ** 2 + x[:, 3] ** 2) + 0.5 * (x[:, 0] ** 2 + x[:, 1] ** 2) \
        + x[:, 0] ** 2 * x[:, 1] - x[:, 1] ** 3 / 3
    assert np.allclose(e, ref, rtol=1e-15, atol=1e-16)
    assert tubes.energy(x[0], hh) == e[0]
    eq = tubes.equilibria(hh)
    assert eq["name"] == ["W1", "S1", "S2", "S3"]
    assert np.allclose(eq["energy"][1:], 1 / 6, atol=1e-15)
    assert np.allclose(eq["lambda"][1:], 1, atol=1e-12)
    assert np.allclose(eq["omega"][1:], np.sqrt(3), atol=1e-12)
    # the section y = 0 (dy/dt > 0) at E = 1/6 + dE: the disc x^2 + px^2 <= 2E
    b = tubes.section_boundary(hh, 0.02, section={"kind": "plane", "index": 2, "value": 0.0, "direction": 1})
    r = np.sqrt(2 * (1 / 6 + 0.02))
    assert abs(b["s_min"] + r) < 1e-12 and abs(b["s_max"] - r) < 1e-12
    assert np.allclose(b["p_max"], np.sqrt(np.maximum(0, r * r - b["s"] ** 2)), atol=1e-7)
    # n_grid: &equilibria's default, range and rule from the reader (41; n_grid^2 <= 1e6 at N = 2)
    sec = {"kind": "plane", "index": 2, "value": 0.0, "direction": 1}
    assert np.array_equal(tubes.section_boundary(hh, 0.02, section=sec, n_grid=41)["s"], b["s"])
    with pytest.raises(ValueError, match=r"section_boundary: &equilibria: n_grid = 1001 is out of range: .*"
                                         r"n_grid\^N Newton starts at most 1e6"):
        tubes.section_boundary(hh, 0.02, section=sec, n_grid=1001)


def test_model_of_a_result_file(tmp_path):
    (tmp_path / "m.nml").write_text("&run scenes = 'equilibria' /\n&model system = 'cr3bp', mu = 0.001 /\n")
    r = run_tubes(["m.nml", "-o", "m.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    m = tubes.Model.of(tubes.load(str(tmp_path / "m.h5")))
    assert m == tubes.Model(system="cr3bp", mu=0.001)


def test_load_keeps_units_nested_paths_and_tables(tmp_path):
    (tmp_path / "t.nml").write_text("&run scenes = 'orbits' /\n&orbits de = 1, 10 /\n")
    r = run_tubes(["t.nml", "-o", "t.h5"], tmp_path)
    assert r.returncode == 0, r.stderr
    res = tubes.load(str(tmp_path / "t.h5"))
    assert res.orbits.units["period"] == "s" and res.orbits.units["action"] == "cm^2/s"
    assert res.units["orbits/action"] == "cm^2/s" and "orbits/period" in res.units
    assert "orbits/nothing" not in res.units and res.units.get("nothing/x", "-") == "-"
    with pytest.raises(KeyError):
        res.units["orbits/nothing"]
    assert "orbits/period" in res and "orbits/nothing" not in res and "model/alpha" in res
    assert np.array_equal(res["orbits/period"], res.orbits.period)
    try:
        import pandas  # noqa: F401
    except ImportError:
        pytest.skip("pandas is not installed")
    df = res.orbits.to_pandas()
    assert list(df.index) == [1.0, 10.0] and df.index.name == "dE" and df.attrs["units"]["period"] == "s"
    ds = res.orbits.to_xarray()
    assert ds["period"].attrs["units"] == "s" and ds.sizes["dE"] == 2 and list(ds["dE"].values) == [1.0, 10.0]


def test_the_calls_tables_convert_in_one_call():
    """The Python calls' tables (orbit_family, transition, equilibria) convert to a DataFrame or an
    xarray Dataset in one call, as a loaded file's groups do: a row per dE (per equilibrium),
    the 1-D columns, names and messages among them; the monodromy (n, 4, 4) is left out."""
    pytest.importorskip("pandas")
    pytest.importorskip("xarray")
    m = tubes.Model()
    o = m.orbit_family(dE=[1.0, 10.0])
    df = o.to_pandas()
    assert list(df.index) == [1.0, 10.0] and np.array_equal(df["action"], o["action"])
    assert "monodromy" not in df.columns and "saddle" not in df.columns
    assert o.to_xarray().sizes["dE"] == 2
    t = m.transition(dE=[100.0]).to_pandas()
    assert list(t.columns) == ["A_tube", "action", "A_E", "p_trans", "p_trans_leading", "status", "message"] and t.index.name == "dE"
    e = m.equilibria().to_pandas()
    assert sorted(e.index) == ["R1", "S12", "S14", "S23", "S34", "W1", "W2", "W3", "W4"]


def test_integrate_validates_as_the_input_file():
    z0 = [4.0, 12.614863819914357, 0.0, 0.0]
    for kw, msg in (({"rtol": -1}, "rtol = -1 is out of range"), ({"atol": 0}, "atol = 0 is out of range"),
                    ({"h": -0.1}, "h = -0.1 is out of range"),
                    ({"section": "theta", "level": 400.0}, "allowed -360 .. 360"),
                    ({"direction": 2, "section": "x"}, "direction = 2")):
        with pytest.raises(ValueError, match=msg):
            tubes.integrate(z0, 1.0, **kw)
    # the ray's angle is in degrees, as in the input file: 45 is the paper's U1 (either branch)
    a = tubes.integrate(z0, 10.0, section="theta", level=45.0)
    b = tubes.integrate(z0, 10.0, section="U1")
    assert np.array_equal(a["crossings"]["t"], b["crossings"]["t"]) and len(a["crossings"]["t"]) > 0


def test_a_copied_tree_imports_its_own_package(tmp_path):
    """The .venv finds python/ by a path relative to its site-packages (Makefile, venv-link), so a
    copy of the tree imports the copy's package. The .venv is copied as a tree of symbolic links
    (half a gigabyte otherwise); the .pth file is read through its link, relative to the copy."""
    root = pathlib.Path(__file__).resolve().parents[1]
    copy = tmp_path / "copy"
    copy.mkdir()
    shutil.copytree(root / "python", copy / "python", ignore=shutil.ignore_patterns("__pycache__"))
    subprocess.run(["cp", "-rs", str(root / ".venv"), str(copy / ".venv")], check=True)
    r = subprocess.run([str(copy / ".venv" / "bin" / "python"), "-c", "import tubes; print(tubes.__file__)"],
                       capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stderr
    assert pathlib.Path(r.stdout.strip()).resolve() == (copy / "python" / "tubes" / "__init__.py").resolve()


def test_status_codes_are_the_library_s():
    """tubes.OK, tubes.EINPUT, ... come from src/base/tubes_status.f90 (no copy in Python): each
    name's number has that status's message, and an unknown name is an AttributeError."""
    words = {"OK": "ok", "EVENT": "terminal event", "EINPUT": "invalid input", "EMAXSTEPS": "maximum number",
             "ESTEP": "underflow", "EMODEL": "refused the state", "EIO": "input/output", "ENOCONV": "converge",
             "EFAULT": "TUBES_FAULT", "EOUTSIDE": "outside the region", "ENOCROSS": "no crossing",
             "EPASTEND": "past the end", "ENARROW": "NHIM's reach", "ENOJET": "no kernel"}
    for name, word in words.items():
        assert word in tubes.status_message(getattr(tubes, name)), name
    assert len({getattr(tubes, n) for n in words}) == len(words)
    with pytest.raises(AttributeError):
        tubes.ENOSUCHCODE  # noqa: B018


def test_model_info_units_and_meanings(tmp_path):
    """tubes.model_info gives each parameter's units and meaning and the coordinates' units: the
    ball's parameters' units are those the namelist table of --help states (another definition,
    src/io/tubes_input.c); a dimensionless system's coordinates are "1"."""
    import re
    ball = tubes.model_info("rolling_ball")
    assert ball["length_units"] == "cm"
    assert list(ball["parameter_units"]) == list(ball["parameters"]) == list(ball["parameter_docs"])
    text = run_tubes(["--help"], tmp_path).stdout
    model = text[text.index("  &model"):text.index("  &equilibria")]     # &model's rows (&experiment has a noise too)
    helped = dict(re.findall(r"^    (\w+)\s+\w+\s+\[(.*?)\]", model, re.M))
    for name, units in ball["parameter_units"].items():
        assert units == helped[name], (name, units, helped[name])
        assert ball["parameter_docs"][name]
    for system in ("henon_heiles", "de_leon_berne", "coupled_quartic", "cr3bp"):
        info = tubes.model_info(system)
        assert info["length_units"] == "1", system
        assert all(u == "1" for u in info["parameter_units"].values()), (system, info["parameter_units"])


def test_equilibria_one_degree_of_freedom_and_its_ranges():
    """A 1-DOF formula, H = p^2/2 - x^2/2 + x^4/4: wells at x = +-1 (E = -1/4), the saddle at 0
    (E = 0, lambda = 1, the root of V'' = -1); no y, no centre frequency. The box and n_grid are
    &equilibria's, refused with its messages."""
    m = tubes.Model(system="expression", hamiltonian="px^2/2 - x^2/2 + x^4/4", coordinates=["x"])
    eq = m.equilibria()
    k = {n: i for i, n in enumerate(eq["name"])}
    assert sorted(eq["x"][[k["W1"], k["W2"]]]) == pytest.approx([-1.0, 1.0], abs=1e-14)
    assert eq["energy"][k["W1"]] == pytest.approx(-0.25, abs=1e-15) and eq["x"][k["S1"]] == pytest.approx(0, abs=1e-15)
    assert eq["lambda"][k["S1"]] == pytest.approx(1.0, rel=1e-14) and eq["rank1"][k["S1"]]
    assert np.all(np.isnan(eq["y"])) and eq["omegas"].shape == (3, 0)
    hh = tubes.Model(system="henon_heiles")
    for kw, msg in (({"box": 0.0}, "equilibria: &equilibria: box = 0 is out of range: allowed > 0"),
                    ({"n_grid": 1}, r"n_grid = 1 is out of range: allowed 2 \.\. 2001"),
                    ({"box": [1, 2, 3]}, "box has 3 values: allowed 1 .every coordinate. or 2")):
        with pytest.raises(ValueError, match=msg):
            hh.equilibria(**kw)


def test_model_methods_have_signatures_and_docs():
    """help(model.transition) shows the keywords and the text (not (*a, _f=..., **k)); the section
    scenes' dE is named dE everywhere (section_boundary's old de still works, deprecated)."""
    import inspect
    m = tubes.Model()
    for name in ("orbit_family", "tube_cut", "transition", "monte_carlo", "poincare", "flux", "equilibria",
                 "section_boundary", "normal_form_map", "synthetic_experiment"):
        sig = inspect.signature(getattr(m, name))
        assert "_f" not in sig.parameters and "model" not in sig.parameters, name
        assert getattr(m, name).__doc__ and len(getattr(m, name).__doc__) > 200, name
        assert name in tubes.__all__, name
    for name in ("orbit_family", "tube_cut", "transition", "monte_carlo", "poincare", "section_boundary"):
        assert "dE" in inspect.signature(getattr(m, name)).parameters, name
        assert "energy units" in getattr(m, name).__doc__, name
    a = m.section_boundary(dE=10.0, m=50)
    with pytest.warns(DeprecationWarning, match="de is deprecated"):
        b = m.section_boundary(de=10.0, m=50)
    assert np.array_equal(a["p_max"], b["p_max"])


def test_model_refusals_point_to_what_is_allowed():
    assert tubes.Model(system="cr3bp", spatial=True).system == "cr3bp_spatial"
    assert tubes.Model(system="cr3bp", spatial=True).ndof == 3
    with pytest.raises(ValueError, match="spatial=True is system='cr3bp_spatial'"):
        tubes.Model(system="henon_heiles", spatial=True)
    m = tubes.Model(surface="expression", height="0.07*(x^2 + y^2) - sqrt(x^2 + 15)")
    with pytest.raises(ValueError, match="needs surface = 'fourwell'"):
        m.synthetic_experiment(n_tracks=1)


def test_the_status_table_of_the_docs_is_the_library_s():
    """docs/usage.md lists every status code with the library's own text (-11 .. -13 were missing)."""
    import re
    rows = dict(re.findall(r"^\| (-?\d+) \| (.+?) \|$", (ROOT / "docs" / "usage.md").read_text(), re.M))
    for code in range(-20, 3):
        assert rows.get(str(code)) == tubes.status_message(code), code
    assert tubes.status_message(-21) == "unknown status code"      # the table ends at -20
    # and every code has its name (tubes.EDIRECTION was missing from Python's copy of the names)
    assert (tubes.ENOJET, tubes.EDIRECTION, tubes.EUNRESOLVED, tubes.ENOREGION, tubes.ESHAPE, tubes.EUNDECIDED,
            tubes.EDISSIPATIVE, tubes.ENOISE, tubes.EINTERRUPT) == (-12, -13, -14, -15, -16, -17, -18, -19, -20)


@pytest.mark.parametrize("call,words", [
    (lambda: tubes.synthetic_experiment(tubes.Model("henon_heiles"), n_tracks=2),
     "needs system = 'rolling_ball', not 'henon_heiles'"),
    (lambda: tubes.orbit_family(tubes.Model("henon_heiles"), dE=[-1]), "de(1) = -1 is out of range"),
], ids=["synthetic_experiment", "orbit_family"])
def test_the_readers_messages_read_right_from_python(call, words):
    """The keywords go through the program's reader (a temporary namelist file): its messages must
    not speak of a file ('this file's system is ...'), nor name the temporary one, nor give the
    ball's units for a dimensionless model."""
    with pytest.raises(ValueError) as e:
        call()
    msg = str(e.value)
    assert words in msg and "file" not in msg and ".nml" not in msg and "cm" not in msg, msg


def test_saddle_near_outside_the_box_is_refused_as_the_program_does():
    """The reader's rule, shared with the input file: a saddle_near outside the &equilibria box
    (where the saddles are searched) took the nearest saddle inside it, however far."""
    m = tubes.Model(system="henon_heiles")
    with pytest.raises(ValueError, match=r"orbit_family: &orbits: saddle_near = \(0, 1\) lies outside the &equilibria box"):
        tubes.orbit_family(m, dE=0.01, saddle_near=(0, 1), equilibria={"box": 0.9})
    assert tubes.orbit_family(m, dE=0.01, saddle_near=(0, 1))["converged"][0]
