"""tubes: phase-space transport between potential wells (tube dynamics).

Python facade of the Fortran core (the f2py extension ``tubes._core``) and the reader of
tubes' HDF5 output. Units: cm and s; energies per unit mass in (cm/s)^2.

    >>> import tubes
    >>> m = tubes.Model()                       # the paper's surface and g
    >>> eq = tubes.equilibria(m)                # dict of arrays, names included
    >>> res = tubes.load("paper.h5")            # an HDF5 result as nested attributes
    >>> res.saddle.T_po, res.trajectory.state.shape
"""
from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

# Status codes: the same numbers as src/tubes_status.f90 and include/tubes.h.
OK, EVENT = 0, 1
EINPUT, EMAXSTEPS, ESTEP, EMODEL, EIO, ENOCONV, EFAULT = -1, -2, -3, -4, -5, -6, -7
_MESSAGES = {
    OK: "ok", EVENT: "stopped at a terminal event", EINPUT: "invalid input",
    EMAXSTEPS: "maximum number of steps reached", ESTEP: "step size underflow",
    EMODEL: "the model refused the state (NaN, Inf or a blown-up state)", EIO: "input/output error",
    ENOCONV: "iteration did not converge", EFAULT: "failure injected by TUBES_FAULT (testing)",
}
METHODS = {"dop853": 1, "rk4": 2, "tao2": 3, "tao4": 4, "tao6": 5, "gauss4": 6, "gauss6": 7,
           "gauss8": 8, "gsl_rk8pd": 9, "gsl_rk4imp": 10, "cvode_adams": 11,
           "arkode_erk8": 12}   # include/tubes.h TUBES_METHOD_*
FIXED_STEP = {"rk4", "tao2", "tao4", "tao6", "gauss4", "gauss6", "gauss8"}

__all__ = ["Model", "TubesError", "energy", "vector_field", "velocity", "momentum",
           "equilibria", "integrate", "trajectory", "reference_solution", "differentiate",
           "load", "Result"]


class TubesError(RuntimeError):
    """A failure reported by the Fortran core; ``code`` is the TUBES_* status; ``partial`` holds
    what was computed up to the failure where the function keeps it (integrate), else None."""

    def __init__(self, code: int, where: str = ""):
        self.code = int(code)
        self.partial = None
        super().__init__(f"{where}: {_MESSAGES.get(self.code, 'unknown status')} (status {self.code})")


def _lib():
    try:
        from . import _core as core  # noqa: PLC0415
    except ImportError as exc:  # pragma: no cover - message for users who skipped `make`
        raise ImportError("tubes._core is not built: run `make` in the tubes directory") from exc
    return core


@dataclasses.dataclass(frozen=True)
class Model:
    """The rolling ball on the four-well surface; defaults are the paper's values."""
    alpha: float = 0.07          # [1/cm]
    beta: float = 1.017          # [1]
    gamma: float = 15.103        # [cm^2]
    xi: float = 0.00656          # [1/cm]
    h0: float = 12.065           # [cm]
    g: float = 981.0             # [cm/s^2]
    damping_ratio: float = 0.0   # [1]

    def params(self) -> np.ndarray:
        return np.array([self.alpha, self.beta, self.gamma, self.xi, self.h0, self.g,
                         self.damping_ratio], dtype=np.float64)


def _check(stat: int, where: str) -> None:
    if stat < 0:
        raise TubesError(stat, where)


def _vec(x, n: int, name: str) -> np.ndarray:
    a = np.array(x, dtype=np.float64, copy=True).reshape(-1)
    if a.size != n:
        raise ValueError(f"{name} must have {n} components, got {a.size}")
    return a


def energy(state, model: Model = Model()) -> float:
    """Energy per unit mass T + g H [(cm/s)^2] of state (x, y, px, py)."""
    stat, e = _lib().energy(model.params(), _vec(state, 4, "state"))
    _check(stat, "energy")
    return float(e)


def vector_field(state, model: Model = Model()) -> np.ndarray:
    """Hamilton's equations d(x, y, px, py)/dt (damped if model.damping_ratio > 0)."""
    stat, f = _lib().vector_field(model.params(), _vec(state, 4, "state"))
    _check(stat, "vector_field")
    return np.asarray(f)


def velocity(state, model: Model = Model()) -> np.ndarray:
    """Planar velocity (dx/dt, dy/dt) [cm/s] of state (x, y, px, py)."""
    stat, v = _lib().velocity(model.params(), _vec(state, 4, "state"))
    _check(stat, "velocity")
    return np.asarray(v)


def momentum(q, v, model: Model = Model()) -> np.ndarray:
    """Momenta p = (7/5) M v [cm/s] at position q with planar velocity v."""
    stat, p = _lib().momentum(model.params(), _vec(q, 2, "q"), _vec(v, 2, "v"))
    _check(stat, "momentum")
    return np.asarray(p)


def equilibria(model: Model = Model(), box: float = 20.0, n_grid: int = 41) -> dict:
    """Critical points of H in |x|, |y| <= box: dict of arrays x, y, height, energy,
    morse_index, name, lambda, omega (rank-1 saddles only), eigenvectors (n, 4, 4)."""
    stat, n, x, y, h, e, morse, names, lam, om, ev = _lib().equilibria(
        model.params(), float(box), int(n_grid))
    _check(stat, "equilibria")
    names = names.decode() if isinstance(names, bytes) else str(names)
    return {"x": x[:n].copy(), "y": y[:n].copy(), "height": h[:n].copy(),
            "energy": e[:n].copy(), "morse_index": morse[:n].copy(),
            "name": names.split()[:n], "lambda": lam[:n].copy(), "omega": om[:n].copy(),
            "eigenvectors": np.moveaxis(ev[:, :, :n], 2, 0).copy()}


SECTIONS = {"U1-": (1, np.pi / 4, 1), "U1+": (1, np.pi / 4, -1), "U1": (1, np.pi / 4, 0)}


def _section(section, level, direction):
    """(kind, level, dir) of a section name (include/tubes.h, tubes_run_trajectory)."""
    if section is None or section == "none":
        return 0, 0.0, 0
    if section in SECTIONS:
        return SECTIONS[section]
    if section == "theta":
        return 1, float(level), int(direction)
    if section in ("x", "y"):
        return (2 if section == "x" else 3), float(level), int(direction)
    raise ValueError(f"unknown section {section!r}; allowed: none, U1-, U1+, U1, theta, x, y")


def integrate(state0, t_end: float, dt_out: float | None = None, model: Model = Model(),
              method: str = "dop853", rtol: float = 1e-12, atol: float = 1e-12, h: float = 0.0,
              max_steps: int = 10_000_000, omega_bind: float = 0.0, solver: str = "newton",
              max_iter: int = 0, section: str | None = None, level: float = 0.0,
              direction: int = 0, stop_at_first: bool = False, max_crossings: int = 10_000) -> dict:
    """Integrate from state0 = (x, y, px, py) at t = 0 to t_end with any method of METHODS.

    Samples every dt_out (default: only the end points). Fixed-step methods need h > 0;
    omega_bind is Tao's binding constant, solver and max_iter configure gauss*.
    section: None, "U1-" (theta = pi/4, p_theta > 0), "U1+", "U1", "theta" (the ray at angle
    `level` [rad], direction = sign of p_theta or 0), "x" or "y" (the line x = level or y = level,
    direction = sign of dx/dt or dy/dt or 0). Every crossing is recorded (on the integrator's
    dense output), up to max_crossings; stop_at_first ends the run at the first one.

    Returns a dict: t (n,), state (n, 4), energy (n,), nfev, nsteps, nrejected, niter, and with
    a section crossings = dict t (m,), state (m, 4), direction (m,), and for theta sections
    r, p_r, p_theta (polar canonical coordinates). Raises TubesError on failure.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; allowed: {', '.join(METHODS)}")
    if method in FIXED_STEP and not h > 0:
        raise ValueError(f"method {method!r} is fixed-step: give h > 0")
    if solver not in ("newton", "fixed_point"):
        raise ValueError("solver must be 'newton' or 'fixed_point'")
    if not t_end >= 0:
        raise ValueError("need t_end >= 0")
    if dt_out is None:
        dt_out = max(t_end, 1e-300)
    if not dt_out > 0:
        raise ValueError("need dt_out > 0")
    kind, lev, dirn = _section(section, level, direction)
    nmax = int(np.floor(t_end / dt_out * (1 + 1e-12))) + 2
    mc = max(1, int(max_crossings))
    stat, n, t, st, en, nc, ct, cx, cd, cnt = _lib().trajectory(
        model.params(), _vec(state0, 4, "state0"), float(t_end), float(dt_out), METHODS[method],
        float(rtol), float(atol), float(h), int(max_steps), float(omega_bind),
        1 if solver == "newton" else 2, int(max_iter), kind, lev, dirn, int(bool(stop_at_first)),
        mc, nmax)
    out = {"t": t[:n].copy(), "state": st[:, :n].T.copy(), "energy": en[:n].copy(),
           "nfev": int(cnt[0]), "nsteps": int(cnt[1]), "nrejected": int(cnt[2]), "niter": int(cnt[3])}
    if kind:
        xs = cx[:, :nc].T.copy()
        cr = {"t": ct[:nc].copy(), "state": xs, "direction": cd[:nc].copy()}
        if kind == 1:
            r = np.hypot(xs[:, 0], xs[:, 1])
            cr.update(r=r, p_r=(xs[:, 0] * xs[:, 2] + xs[:, 1] * xs[:, 3]) / r,
                      p_theta=xs[:, 0] * xs[:, 3] - xs[:, 1] * xs[:, 2])
        out["crossings"] = cr
    if stat < 0:   # keep what was computed up to the failure: err.partial
        err = TubesError(stat, "integrate")
        err.partial = out
        raise err
    return out


def trajectory(state0, t_end: float, dt_out: float = 0.01, **kw) -> dict:
    """integrate() sampled every dt_out (default 0.01 s); see integrate for the options."""
    return integrate(state0, t_end, dt_out=dt_out, **kw)


def reference_solution(state0, t_end: float, tol: float = 1e-26, model: Model = Model()) -> np.ndarray:
    """Quad-precision (real128) DOP853 solution at t_end, rounded to double: the reference
    that tests and benchmarks measure errors against (conservative model only; docs/events.md
    gives its accuracy and cost: tol 1e-26 to t = 10 s takes about 2 s)."""
    if model.damping_ratio != 0:
        raise ValueError("reference_solution: conservative model only")
    stat, x, _, _ = _lib().reference_solution(model.params(), _vec(state0, 4, "state0"),
                                              float(t_end), float(tol))
    _check(stat, "reference_solution")
    return np.asarray(x)


EDGES = {"periodic": 0, "odd": 1, "mirror": 2}   # src/tubes_differentiate.f90 EDGE_*
_DIFF_OPTIONS = {"spectral": {"cutoff": 5.0, "rolloff": 0.5, "edge": "mirror", "end_order": 3,
                              "end_window": None},
                 "savgol": {"order": 3, "window": 15}}


def differentiate(x, dt: float, method: str = "spectral", **options):
    """Velocity and smoothed position of samples x taken every dt [s] (src/tubes_differentiate.f90,
    docs/experiment-data.md). x is 1-D (n,) or 2-D (n, k): each column is one coordinate.

    method="spectral" (FFTW): options cutoff [Hz] (half-gain frequency of the raised-cosine
    low-pass filter; None or 0 = no filter; default 5), rolloff (transition width / cutoff,
    0 <= rolloff < 2; default 0.5), edge ("mirror": subtract a quadratic with the end slopes of
    local fits and extend evenly, the default; "odd": subtract the line through the end samples
    and extend oddly; "periodic": none), end_order (degree of the mirror's end fits, default 3),
    end_window (their samples; default two cutoff periods, end_order + 4 without a filter).
    method="savgol" (Savitzky-Golay): options order (polynomial degree, default 3) and window
    (odd number of samples, default 15); the ends use the shifted window.

    Returns (velocity, smoothed), arrays shaped like x. Raises TubesError on invalid input.
    """
    if method not in _DIFF_OPTIONS:
        raise ValueError(f"unknown method {method!r}; allowed: spectral, savgol")
    unknown = set(options) - set(_DIFF_OPTIONS[method])
    if unknown:
        raise TypeError(f"differentiate({method!r}): unknown option(s) {sorted(unknown)}; "
                        f"allowed: {sorted(_DIFF_OPTIONS[method])}")
    opt = dict(_DIFF_OPTIONS[method], **options)
    a = np.array(x, dtype=np.float64, copy=True)
    if a.ndim not in (1, 2):
        raise ValueError("x must be 1-D (n,) or 2-D (n, k)")
    cols = a.reshape(a.shape[0], -1)
    v = np.empty_like(cols)
    xs = np.empty_like(cols)
    lib = _lib()
    for j in range(cols.shape[1]):
        c = np.ascontiguousarray(cols[:, j])
        if method == "spectral":
            if opt["edge"] not in EDGES:
                raise ValueError(f"unknown edge {opt['edge']!r}; allowed: {', '.join(EDGES)}")
            cutoff = 0.0 if opt["cutoff"] is None else float(opt["cutoff"])
            ew = 0 if opt["end_window"] is None else int(opt["end_window"])
            stat, vj, xj = lib.differentiate_spectral(c, float(dt), cutoff, float(opt["rolloff"]),
                                                      EDGES[opt["edge"]], int(opt["end_order"]), ew)
        else:
            stat, vj, xj = lib.differentiate_savgol(c, float(dt), int(opt["order"]), int(opt["window"]))
        _check(stat, f"differentiate({method!r})")
        v[:, j] = vj
        xs[:, j] = xj
    return v.reshape(a.shape), xs.reshape(a.shape)


class Result:
    """An HDF5 group of a tubes output: attributes and datasets as Python attributes
    (datasets as numpy arrays, strings decoded), subgroups as nested Results."""

    def __init__(self, name: str, attrs: dict, items: dict):
        self._name, self.attrs, self._items = name, attrs, items

    def __getattr__(self, key: str) -> Any:
        items = self.__dict__.get("_items", {})
        if key in items:
            return items[key]
        attrs = self.__dict__.get("attrs", {})
        if key in attrs:
            return attrs[key]
        raise AttributeError(f"{self.__dict__.get('_name', '?')} has no dataset, group or "
                             f"attribute {key!r}")

    def __getitem__(self, key: str) -> Any:
        node: Any = self
        for part in key.strip("/").split("/"):
            node = getattr(node, part)
        return node

    def __contains__(self, key: str) -> bool:
        return key in self._items or key in self.attrs

    def keys(self):
        return list(self._items) + list(self.attrs)

    def __repr__(self) -> str:
        return f"<tubes.Result {self._name}: {', '.join(self.keys())}>"


def _decode(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.dtype.kind in "OS":
        return [x.decode() if isinstance(x, bytes) else x for x in v.tolist()]
    if isinstance(v, np.generic):
        return v.item()
    return v


def _read(node, name: str) -> Result:
    import h5py
    attrs = {k: _decode(v) for k, v in node.attrs.items()}
    items: dict = {}
    for k, v in node.items():
        items[k] = _read(v, f"{name}/{k}".replace("//", "/")) if isinstance(v, h5py.Group) \
            else _decode(v[()])
    return Result(name, attrs, items)


def load(path: str) -> Result:
    """Read a tubes HDF5 output completely into memory."""
    import h5py
    with h5py.File(path, "r") as f:
        return _read(f, "/")
