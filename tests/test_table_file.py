"""Issue 37, item 5: each scene's Python Table has its output group's columns and units. The
program writes a group per scene (the C writer, its units from src/io/tubes_units.c); the Python
call computes the same scene through the core. For every dataset and attribute of the group the
Table has a key of that name, the same numbers (bit for bit: the same core computes both) and,
for a dataset, the units the file gives it, for the rolling ball (cm, s) and for a dimensionless
model ("1")."""
import h5py
import numpy as np
import pytest
import tubes
from conftest import run_tubes

# What the file has and the Table has not, with the reason. Nothing else may be missing.
NOT_IN_TABLE = {
    "/tracks": {"method", "status"},   # the scene's integrator label and exit status
}


# States: their units depend on the degrees of freedom, given where each is written (not in the
# units table, src/io/tubes_units.c): "cm, cm, cm/s, cm/s" for the ball, "state units" else.
STATES = {"state", "state0", "states"}


def _run(tmp_path, text):
    (tmp_path / "s.nml").write_text(text)
    r = run_tubes(["s.nml", "-o", "s.h5"], tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    return h5py.File(tmp_path / "s.h5", "r")


def _same(a, b):
    if isinstance(b, bytes):
        b = b.decode()
    if isinstance(a, (str, bytes)) or isinstance(b, str):
        return str(a) == str(b)
    a, b = np.asarray(a), np.asarray(b)
    if b.dtype.kind in "OS":      # names: strings
        return [x.decode() if isinstance(x, bytes) else x for x in b.tolist()] == list(a)
    if a.dtype == bool or b.dtype == bool:
        a, b = a.astype(int), b.astype(int)
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


def _compare(table, g, group, skip_values=()):
    """Every dataset and attribute of the file's group g is a key of the table with the same value,
    and every dataset's units are the table's."""
    assert isinstance(table, tubes.Table)
    missing = set()
    for k, v in list(g.items()) + list(g.attrs.items()):
        if isinstance(v, h5py.Group):
            continue
        if k not in table:
            missing.add(k)
            continue
        if k not in skip_values:
            file_value = v[()] if isinstance(v, h5py.Dataset) else v
            assert _same(table[k], file_value), (group, k, table[k], file_value)
        if isinstance(v, h5py.Dataset) and "units" in v.attrs:
            u = v.attrs["units"]
            u = u.decode() if isinstance(u, bytes) else u
            if k not in STATES:
                assert table.units.get(k) == u, (group, k, table.units.get(k), u)
    assert missing == NOT_IN_TABLE.get(group, set()), (group, missing)


BALL = ("&run scenes = 'equilibria', 'orbits', 'tubes', 'transition', 'montecarlo', 'sections' /\n"
        "&orbits de = 1, 50 /\n&tubes de = 100 /\n&transition de = 10, 100 /\n"
        "&montecarlo de = 100, n_samples = 300, seed = 4 /\n&sections de = 100, n_seeds = 3, n_iter = 5 /\n")


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("ball"), BALL)


def test_the_ball_s_tables_are_its_file_s_groups(ball):
    m = tubes.Model()
    _compare(m.equilibria(), ball["equilibria"], "/equilibria", skip_values=("box",))
    assert ball["equilibria"].attrs["box"] == 20.0 and np.all(m.equilibria().box == 20.0)
    _compare(m.orbit_family(dE=[1, 50]), ball["orbits"], "/orbits")
    _compare(m.tube_cut(dE=100), ball["tubes/stable_000"], "/tubes/stable_000")
    _compare(m.transition(dE=[10, 100]), ball["transition"], "/transition")
    mc = m.monte_carlo(dE=100, n_samples=300, seed=4, check=False)
    _compare(mc, ball["montecarlo"], "/montecarlo")
    _compare(m.poincare(100, n_seeds=3, n_iter=5), ball["sections/map_000"], "/sections/map_000")


def test_the_leading_order_is_the_closed_form_of_the_section_s_numbers(ball):
    """p_trans_leading = (T_po/A0) dE (1 - tau dE/A0), from the file's /section attributes (the
    saddle's T_po, A0, tau): the Table's and the file's columns against the formula."""
    s = ball["section"].attrs
    de = np.array([10.0, 100.0])
    expected = s["T_po"] / s["A0"] * de * (1 - s["tau"] / s["A0"] * de)
    t = tubes.Model().transition(dE=de)
    assert np.allclose(t.p_trans_leading, expected, rtol=1e-14, atol=0)
    assert t.units["p_trans_leading"] == "1" and t.units["A_tube"] == "cm^2/s" and t.units["dE"] == "(cm/s)^2"


def test_tables_carry_units_into_pandas_and_xarray():
    pytest.importorskip("pandas")
    pytest.importorskip("xarray")
    t = tubes.Model().orbit_family(dE=[1.0, 10.0])
    assert t.units["period"] == "s" and t.units["dE"] == "(cm/s)^2" and t.units["action"] == "cm^2/s"
    assert t.to_pandas().attrs["units"]["period"] == "s"
    ds = t.to_xarray()
    assert ds["period"].attrs["units"] == "s" and ds["dE"].attrs["units"] == "(cm/s)^2"


HH = ("&model system = 'henon_heiles' /\n&run scenes = 'equilibria', 'orbits', 'tubes', 'transition' /\n"
      "&orbits de = 0.01 /\n&tubes de = 0.01 /\n&transition de = 0.01 /\n")


def test_a_dimensionless_model_s_tables_are_its_file_s_groups(tmp_path):
    f = _run(tmp_path, HH)
    m = tubes.Model(system="henon_heiles")
    eq = m.equilibria()
    _compare(eq, f["equilibria"], "/equilibria", skip_values=("box",))
    assert eq.units["x"] == "1" and eq.units["omega"] == "rad"
    o = m.orbit_family(dE=[0.01])
    _compare(o, f["orbits"], "/orbits")
    assert o.units["period"] == "1"
    _compare(m.tube_cut(dE=0.01), f["tubes/stable_000"], "/tubes/stable_000")
    _compare(m.transition(dE=[0.01]), f["transition"], "/transition")


def test_a_synthetic_experiment_s_table_is_its_file_s_group(tmp_path):
    f = _run(tmp_path, "&run scenes = 'synthetic_experiment' /\n&experiment n_tracks = 2, duration = 1.0, seed = 5 /\n")
    t = tubes.Model().synthetic_experiment(n_tracks=2, duration=1.0, seed=5)
    _compare(t, f["tracks"], "/tracks")
    assert t.units["x"] == "cm" and t.units["t"] == "s" and t.units["track"] == "1"


def test_plots_of_a_table_are_labelled_with_its_units():
    """tubes.plots on a Table computed in Python, no file and no model given: the axis labels carry
    the Table's units (the ball's (cm/s)^2 and s; none for Hénon–Heiles)."""
    pytest.importorskip("matplotlib")
    from tubes import plots
    ball = tubes.Model().orbit_family(dE=[1.0, 10.0])
    ax = plots.orbit_period(ball)
    assert "(cm/s)^2" in ax.get_xlabel() and "[s]" in ax.get_ylabel()
    hh = tubes.Model(system="henon_heiles").orbit_family(dE=[0.01, 0.02])
    ax = plots.orbit_period(hh)
    assert "cm" not in ax.get_xlabel() + ax.get_ylabel() and "[s]" not in ax.get_ylabel()
    ax = plots.p_trans(tubes.Model().transition(dE=[10.0, 100.0]))
    assert "(cm/s)^2" in ax.get_xlabel()


def test_the_orbit_family_s_bifurcations_are_the_file_s(tmp_path):
    """The spatial Earth-Moon CR3BP's L1 Lyapunov family across its halo branch point (issue 38):
    orbit_family's floquet_index and bifurcations (a dict of the file's /orbits/bifurcations) are
    the orbits scene's, bit for bit; the halo family by name too."""
    f = _run(tmp_path, "&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                       "&orbits saddle = 'L1', family = 2, de = 0.004, 0.006, 0.008 /\n")
    m = tubes.Model(system="cr3bp", spatial=True)
    o = m.orbit_family(dE=[0.004, 0.006, 0.008], saddle="L1", family=2)
    _compare(o, f["orbits"], "/orbits")
    b, g = o.bifurcations, f["orbits/bifurcations"]
    assert list(b["kind"]) == [1]                                   # the branch point, found by both
    for k in g:
        assert np.array_equal(b[k], g[k][()]), k
    assert b["tol"] == g.attrs["tol"]
    (tmp_path / "halo").mkdir()
    f2 = _run(tmp_path / "halo", "&run scenes = 'orbits' /\n&model system = 'cr3bp', spatial = .true. /\n"
                               "&orbits saddle = 'L1', family = 'halo_north', de = 0.01 /\n")
    h = m.orbit_family(dE=[0.01], saddle="L1", family="halo_north")
    assert h.family_name == "halo_north" == f2["orbits"].attrs["family_name"]
    for k in ("period", "state0", "energy"):
        assert np.array_equal(h[k], f2["orbits"][k][()]), k
