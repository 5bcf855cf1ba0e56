"""Issue 37, item 5: every scene call returns one type, tubes.Table: a dict (the old keys of
monte_carlo's dict still read as result['key']) whose columns also read as attributes, and whose
to_pandas() / to_xarray() are labelled by dE (a row per excess energy) or by name (a row per
equilibrium), as a loaded file's groups are."""
import numpy as np
import pytest

import tubes

M = tubes.Model()
MC_KEYS = ("dE", "n_samples", "seed", "fraction", "std_error", "p_trans", "misclassified",
           "misclassified_inside_no_transit", "misclassified_outside_transit", "undecided", "escaped",
           "agrees", "sigmas", "sigma_limit", "misclassified_limit", "undecided_limit", "r", "p_r", "transit",
           "inside")


@pytest.fixture(scope="module")
def mc():
    return M.monte_carlo(dE=100.0, n_samples=200, check=False)


def test_monte_carlo_returns_a_table_with_its_old_keys(mc):
    assert isinstance(mc, tubes.Table)
    for k in MC_KEYS:
        assert k in mc, k
        assert mc[k] is getattr(mc, k)          # the same object, by key and by attribute
    assert mc.n_samples == 200


@pytest.mark.parametrize("call", [lambda: M.section_boundary(dE=10.0, m=20),
                                  lambda: M.tube_cut(dE=10.0),
                                  lambda: M.transition_region(dE=10.0)],
                         ids=["section_boundary", "tube_cut", "transition_region"])
def test_every_scene_call_returns_a_table(call):
    assert isinstance(call(), tubes.Table)


def test_a_columns_reads_as_an_attribute():
    fam = M.orbit_family(dE=[1.0, 10.0])
    assert fam.period is fam["period"]
    with pytest.raises(AttributeError, match="has no column 'nothing'"):
        fam.nothing


def test_tables_are_labelled_by_de():
    pytest.importorskip("pandas")
    xr = pytest.importorskip("xarray")
    fam = M.orbit_family(dE=[1.0, 10.0])
    df = fam.to_pandas()
    assert df.index.name == "dE" and list(df.index) == [1.0, 10.0]
    assert np.array_equal(df.loc[10.0, "period"], fam.period[1])
    ds = fam.to_xarray()
    assert isinstance(ds, xr.Dataset) and list(ds["dE"].values) == [1.0, 10.0]
    assert float(ds["period"].sel(dE=10.0)) == fam.period[1]


def test_equilibria_are_labelled_by_name():
    pytest.importorskip("pandas")
    eq = M.equilibria()
    df = eq.to_pandas()
    assert df.index.name == "name" and df.loc["S12", "energy"] == eq.energy[eq.name.index("S12")]


def test_monte_carlo_has_the_file_s_status(mc):
    """/montecarlo@status (0 where the check was made) is in the Python result too."""
    assert mc.status == 0
