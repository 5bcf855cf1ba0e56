"""Helpers shared by the test files (not tests themselves): a Newton iteration on a central-difference
Jacobian for the independent scipy correctors, and the program's orbits scene run on a namelist
written here, with its /orbits read back."""
import h5py
import numpy as np

from conftest import run_tubes

SPATIAL_CR3BP = "&model system = 'cr3bp', spatial = .true. /\n"   # the Earth-Moon CR3BP in 3-D


def newton(f, u, maxit, tol=1e-13, h=1e-7):
    """Newton on f(u) = 0 (as many equations as unknowns) from u: the Jacobian by central
    differences of step h in each unknown; stops once max |f(u)| < tol or after maxit steps.
    Returns u; the caller checks the residual it needs."""
    u = np.array(u, float)
    for _ in range(maxit):
        r = f(u)
        if np.max(np.abs(r)) < tol:
            break
        j = np.empty((len(r), len(u)))
        for i in range(len(u)):
            du = np.zeros(len(u))
            du[i] = h
            j[:, i] = (f(u + du) - f(u - du)) / (2 * h)
        u = u - np.linalg.solve(j, r)
    return u


def run_orbits(tmp_path, name, model, orbits, timeout=300, scenes="'orbits'", more=None):
    """./tubes on tmp_path/{name}.nml: &run scenes (the orbits scene alone by default) with output
    {name}.h5, the &model group `model` (a whole line) and &orbits `orbits` (its variables). Returns
    the CompletedProcess and the output's /orbits: its datasets (not its groups) by name and its
    attributes as "attrs", with what more(f) returns (a dict; f the open output file) added; None
    without that file or group."""
    (tmp_path / f"{name}.nml").write_text(f"&run scenes = {scenes}, output = '{name}.h5' /\n{model}"
                                          f"&orbits {orbits} /\n")
    r = run_tubes([f"{name}.nml"], cwd=tmp_path, timeout=timeout)
    out = None
    if (tmp_path / f"{name}.h5").exists():
        with h5py.File(tmp_path / f"{name}.h5") as f:
            if "orbits" in f:
                g = f["orbits"]
                out = {k: g[k][()] for k in g if not isinstance(g[k], h5py.Group)}
                out["attrs"] = dict(g.attrs)
                if more is not None:
                    out.update(more(f))
    return r, out
