"""tubes.h5compare, the bitwise comparison make check uses for the MPI flavour: it must see a
one-ulp change, a moved NaN, a missing dataset and a changed attribute, and skip provenance."""
import h5py
import numpy as np

from tubes.h5compare import compare, main

from conftest import run_tubes


def write(path, data, attrs=None, extra=None):
    with h5py.File(path, "w") as f:
        f.attrs["created"] = str(path)             # provenance: differs, must be skipped
        f.attrs["mpi_ranks"] = 1 if "a" in str(path.name) else 2
        g = f.create_group("tubes")
        d = g.create_dataset("r", data=data)
        d.attrs["units"] = "cm"
        for k, v in (attrs or {}).items():
            g.attrs[k] = v
        if extra:
            f.create_dataset(extra, data=[1, 2, 3])


def test_identical_files_agree(tmp_path):
    x = np.array([1.0, np.nan, 3.0])
    write(tmp_path / "a.h5", x, {"area": 75.78})
    write(tmp_path / "b.h5", x.copy(), {"area": 75.78})
    assert compare(str(tmp_path / "a.h5"), str(tmp_path / "b.h5")) == []
    assert main([str(tmp_path / "a.h5"), str(tmp_path / "b.h5")]) == 0


def test_one_ulp_is_a_difference(tmp_path):
    x = np.array([1.0, 2.0, 3.0])
    y = x.copy()
    y[1] = np.nextafter(2.0, 3.0)
    write(tmp_path / "a.h5", x)
    write(tmp_path / "b.h5", y)
    d = compare(str(tmp_path / "a.h5"), str(tmp_path / "b.h5"))
    assert len(d) == 1 and "/tubes/r" in d[0] and "1 of 3 differ" in d[0]
    assert compare(str(tmp_path / "a.h5"), str(tmp_path / "b.h5"), rtol=1e-15) == []   # 1 ulp of 2 = 2.2e-16 relative
    assert main([str(tmp_path / "a.h5"), str(tmp_path / "b.h5")]) == 1


def test_nan_attribute_and_structure(tmp_path):
    write(tmp_path / "a.h5", np.array([np.nan, 1.0]), {"area": 1.0})
    write(tmp_path / "b.h5", np.array([1.0, np.nan]), {"area": 2.0}, extra="more")
    d = "\n".join(compare(str(tmp_path / "a.h5"), str(tmp_path / "b.h5")))
    assert "NaN at different places" in d
    assert "/tubes@area" in d
    assert "/more: only in B" in d
    assert "mpi_ranks" not in d and "created" not in d


def test_the_output_path_is_provenance(tmp_path):
    (tmp_path / "e.nml").write_text("&run scenes = 'equilibria', output = 'a.h5' /\n")
    assert run_tubes(["e.nml"], tmp_path).returncode == 0
    assert run_tubes(["e.nml", "-o", "b.h5"], tmp_path).returncode == 0
    from tubes.h5compare import compare
    diffs = [d for d in compare(str(tmp_path / "a.h5"), str(tmp_path / "b.h5")) if "git_commit" not in d]
    assert diffs == []
