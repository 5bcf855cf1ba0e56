"""The flux's samples and the synthetic experiment's tracks in the Taylor method's lanes (issue 36;
docs/integrators-taylor.md, "Ensembles in lanes"): an item's numbers do not depend on the lanes'
width (TUBES_LANES 1, 2, 8) nor on the number of OpenMP threads (items fall into other lanes and
chunks), bit for bit. The sampled flux's agreement with independent references is
tests/test_flux.py's; each lane's agreement with a lone integration, tests/test_lanes.f90's."""
import os
import subprocess
import textwrap

import h5py
import numpy as np
import pytest

from conftest import TIMEOUT_SCALE, TUBES

# (threads, lanes' width): the first is the reference
RUNS = (("1", "1"), ("2", "2"), ("1", "8"), ("2", "8"))


@pytest.fixture(scope="module")
def cache(model_cache):
    return model_cache          # the tests' shared model cache (conftest.py)


def run_all(tmp, text, cache, groups):
    """The input text at every (threads, width) of RUNS: each run's datasets under groups, by path."""
    out = {}
    for th, w in RUNS:
        name = f"r{th}_{w}"
        path = os.path.join(tmp, name + ".nml")
        with open(path, "w") as f:
            f.write(textwrap.dedent(text.format(out=name + ".h5")))
        p = subprocess.run([str(TUBES), path], cwd=tmp, capture_output=True, text=True, timeout=300 * TIMEOUT_SCALE,
                           env=dict(os.environ, OMP_NUM_THREADS=th, TUBES_LANES=w, TUBES_CACHE_DIR=cache))
        assert p.returncode == 0, p.stdout + p.stderr
        d = {}
        with h5py.File(os.path.join(tmp, name + ".h5")) as f:
            assert int(f.attrs["taylor_lanes"]) == int(w)
            for g in groups:
                f[g].visititems(lambda k, v, g=g: d.__setitem__(f"{g}/{k}", v[()])
                                if isinstance(v, h5py.Dataset) else None)
        out[(th, w)] = d
    return out


def assert_same(out, min_datasets):
    ref = out[RUNS[0]]
    assert len(ref) >= min_datasets, sorted(ref)
    for key, d in out.items():
        assert sorted(d) == sorted(ref), key
        for k in ref:
            assert np.array_equal(np.asarray(d[k]), np.asarray(ref[k]), equal_nan=True), (key, k)


def test_two_dof_flux_samples_in_lanes(tmp_path, cache):
    """The ball's sampled flux (each sample's future and past, slab observers) at three energies."""
    out = run_all(str(tmp_path), """\
        &run scenes = 'flux', output = '{out}' /
        &integrator method = 'taylor' /
        &flux de = 10, 400, 700, n_samples = 1500, seed = 11 /
        """, cache, ["flux"])
    assert_same(out, 4)
    f = out[RUNS[0]]
    assert np.all(f["flux/n_reacting"] > 0) and np.all(np.isfinite(f["flux/flux_sampled"])), f


def test_three_dof_flux_and_section_in_lanes(tmp_path, cache):
    """A 3-DOF formula model: the sampled flux and the section's transition fraction (each point
    followed forwards until it transits or returns: transit observers): the counts, the volume
    and the fraction (sums over every sample)."""
    out = run_all(str(tmp_path), """\
        &run scenes = 'equilibria', 'flux', output = '{out}' /
        &model system = 'expression',
          hamiltonian = '(p1^2 + p2^2 + p3^2)/2 - q1^2/2 + q1^4/4 + w2^2*q2^2/2 + w3^2*q3^2/2 + a*q1^2*q2^2',
          coordinates = 'q1', 'q2', 'q3', momenta = 'p1', 'p2', 'p3',
          constants = 'w2 = 1.3', 'w3 = 2.1', 'a = 0.2' /
        &equilibria box = 1.2, n_grid = 5 /
        &section kind = 'plane', index = 1, value = -0.7, direction = 1 /
        &flux de = 0.05, n_samples = 1500, seed = 3, n_cut = 0 /
        """, cache, ["flux"])
    assert_same(out, 6)


def test_synthetic_tracks_in_lanes(tmp_path, cache):
    """The damped ball's synthetic tracks (the frames' sampler as each lane's observer)."""
    out = run_all(str(tmp_path), """\
        &run scenes = 'synthetic_experiment', output = '{out}' /
        &integrator method = 'taylor' /
        &experiment n_tracks = 13, duration = 3.0, camera_rate = 50.0, damping_ratio = 0.0025,
          de_min = 200.0, de_max = 1000.0, seed = 5 /
        """, cache, ["tracks"])
    assert_same(out, 4)
