"""tubes: phase-space transport between potential wells (tube dynamics).

Python facade of the Fortran core (the f2py extension ``tubes._core``) and the reader of
tubes' HDF5 output. Models come from the library (docs/models.md); the rolling ball's units are
cm and s, energies per unit mass in (cm/s)^2.

    >>> import tubes
    >>> m = tubes.Model()                       # the paper's surface and g
    >>> hh = tubes.Model(system="henon_heiles")
    >>> eq = tubes.equilibria(m)                # dict of arrays, names included
    >>> res = tubes.load("paper.h5")            # an HDF5 result as nested attributes
    >>> res.saddle.T_po, res.trajectory.state.shape
"""
from __future__ import annotations

import functools
import math
import numbers
import re
import sys
import threading
from typing import Any

import numpy as np

from . import _args

def __getattr__(name: str):
    """The status codes tubes.OK, tubes.EVENT, tubes.EINPUT, ... (TUBES_<name>): their numbers from
    the library's one definition (src/base/tubes_status.f90), looked up on first use; and
    tubes.MC_SIGMA, the Monte Carlo check's limit in standard errors (the program's,
    src/transport/tubes_transport.f90)."""
    if name == "MC_SIGMA":
        return float(_lib().mc_agreement(1, 0, 0, 0, 0.5)[1])
    if name.isupper() and name.isalpha():
        code = int(_lib().status_code(name))
        if code != 1000:
            globals()[name] = code
            return code
    raise AttributeError(f"module 'tubes' has no attribute {name!r}")


def status_message(code: int) -> str:
    """The meaning of a TUBES_* status code, from the library's one table (src/base/tubes_status.f90)."""
    msg = _lib().status_text(int(code))
    return (msg.decode() if isinstance(msg, bytes) else str(msg)).strip()


METHODS = {"dop853": 1, "rk4": 2, "tao2": 3, "tao4": 4, "tao6": 5, "gauss4": 6, "gauss6": 7,
           "gauss8": 8, "gsl_rk8pd": 9, "gsl_rk4imp": 10, "cvode_adams": 11,
           "arkode_erk8": 12, "taylor": 13, "auto": 14}   # include/tubes.h TUBES_METHOD_*
FIXED_STEP = {"rk4", "tao2", "tao4", "tao6", "gauss4", "gauss6", "gauss8"}

__all__ = ["Model", "Table", "TubesError", "DisagreementError", "MC_SIGMA", "conservative", "Integrator", "ensemble", "status_message", "systems", "model_info", "energy", "energies", "potentials",
           "shape_derivatives", "vector_field", "velocity", "momentum", "equilibria",
           "section_boundary", "integrate", "trajectory", "reference_solution", "differentiate",
           "orbit_family", "tube_cut", "transition", "transition_region", "monte_carlo", "poincare", "flux",
           "normal_form_map", "scan",
           "synthetic_experiment", "load", "Result"]


class TubesError(RuntimeError):
    """A failure reported by the Fortran core; ``code`` is the TUBES_* status; ``partial`` holds
    what was computed up to the failure where the function keeps it (integrate), else None."""

    def __init__(self, code: int, where: str = ""):
        self.code = int(code)
        self.partial = None
        super().__init__(f"{where}: {status_message(self.code)} (status {self.code})")


def _lib():
    global _CORE
    if _CORE is None:
        try:
            from . import _core as core  # noqa: PLC0415
        except ImportError as exc:  # pragma: no cover - message for users who skipped `make`
            raise ImportError("tubes._core is not built: run `make` in the tubes directory") from exc
        _codegen_env()   # the Taylor method's kernels of any model are generated too (pip install)
        _CORE = _Interruptible(core)
    return _CORE


_CORE = None


#: progress lines of the long ensembles on stderr during a call ("  400000 of 4000000 points (10%),
#: 1.0 s, about 9 s left", at most once a second once a loop has run a second; the program's lines,
#: src/base/tubes_progress_shim.c): None (the default) shows them when stderr is a terminal, True
#: always, False never (docs/python.md, "Progress").
progress = None


def _progress_on() -> bool:
    if progress is None:
        try:
            return sys.stderr.isatty()
        except (AttributeError, ValueError):
            return False
    return bool(progress)


class _Interruptible:
    """The core's calls with Ctrl-C. While the core computes, Python's SIGINT handler only notes
    the signal (the KeyboardInterrupt came when the call ended: 66 s after Ctrl-C on a 10^7-point
    Monte Carlo). A call from the main thread installs the core's handler for its duration
    (src/base/tubes_cancel_shim.c): the ensembles stop dealing out work, the call returns within
    one unit of work, and KeyboardInterrupt is raised here. What the models had kept is dropped
    then (an orbit continuation cut short must not be kept as the family's end)."""

    def __init__(self, core):
        self._core = core

    def __getattr__(self, name):
        f = getattr(self._core, name)
        if not callable(f) or name.startswith("cancel_"):
            return f
        core = self._core

        def call(*args, **kwargs):
            import threading  # noqa: PLC0415
            if threading.current_thread() is not threading.main_thread() or _Interruptible.depth:
                return f(*args, **kwargs)
            _Interruptible.depth += 1
            core.cancel_begin()
            shown = _progress_on()
            if shown:
                core.progress_enable(1)
            try:
                result = f(*args, **kwargs)
            finally:
                _Interruptible.depth -= 1
                if shown:
                    core.progress_enable(0)
                hit = core.cancel_end()
                if hit:
                    _Stores.drop_all()
            if hit:
                raise KeyboardInterrupt
            return result
        return call

    depth = 0


class Model:
    """A model of the library (docs/models.md), chosen by name and parametrised by keyword:

        tubes.Model()                                   # the paper's four-well ball
        tubes.Model(alpha=0.08)                         # the ball with another bowl
        tubes.Model(system="henon_heiles")
        tubes.Model(system="cr3bp", mu=0.000953875)     # Sun-Jupiter

    or written as a formula (docs/models.md, "Models from the input file"), a string or a SymPy
    expression, with constants as a dict or as 'name = value' strings:

        tubes.Model(system="expression", hamiltonian="(px^2 + py^2)/2 + x^4/4 - x^2/2 + y^2/2")
        tubes.Model(system="expression", hamiltonian=H, coordinates=(q1, q2, q3),
                    momenta=(p1, p2, p3), constants={"k": 2.0})        # SymPy symbols
        tubes.Model(surface="expression", height="0.07*(x^2 + y^2) - sqrt(x^2 + 15)")

    The parameters, their defaults and their order come from the Fortran table
    (src/models/tubes_models.f90): a keyword that is not a parameter of the system is refused with the
    system's parameters named, as the input file refuses it. ``model.alpha`` reads a parameter;
    ``model.parameters`` is the dict of all of them; ``model.params()`` the vector the core
    takes.

    A Model keeps what its calls compute for later ones, as the program's run does: the
    equilibria, each orbit family's continuation and orbits, and each tube cut's seeds
    (src/workflow/tubes_study.f90, seed_stores_t). A second call gives the same bits as a first
    (a call with another Model, or with model=None, starts afresh); ``model.kept()`` counts what
    is kept and ``model.forget()`` frees it."""

    __slots__ = ("system", "parameters", "ndof", "_vector", "info", "name", "formula", "_kept")

    def __init__(self, system: str = "rolling_ball", *, hamiltonian=None, coordinates=None, momenta=None,
                 constants=None, surface=None, height=None, **parameters):
        if "spatial" in parameters:   # the input file's &model spatial (cr3bp only)
            spatial = parameters.pop("spatial")
            if system != "cr3bp":
                raise ValueError(f"Model: spatial belongs to system 'cr3bp' (spatial=True is system='cr3bp_spatial'), "
                                 f"not to system {system!r}")
            if spatial not in (True, False):
                raise ValueError(f"Model: spatial = {spatial!r}: allowed True (system 'cr3bp_spatial') or False")
            system = "cr3bp_spatial" if spatial else system
        formula = _formula(system, hamiltonian, coordinates, momenta, constants, surface, height)
        object.__setattr__(self, "formula", formula)
        name = system
        if formula:
            # the program's reader builds (or finds in the cache) the model's library: its name
            _codegen_env()
            name = _str(_read_namelist([_formula_nml(system, formula)], "Model")["system"])
        info = model_info(name)
        unknown = sorted(set(parameters) - set(info["parameters"]))
        if unknown:
            allowed = ", ".join(info["parameters"]) or "none"
            raise ValueError(f"Model: {', '.join(unknown)} is not a parameter of system {system!r} "
                             f"(its parameters: {allowed})")
        values = dict(info["parameters"])
        for k, v in parameters.items():
            values[k] = _args.real("Model", k, v)
        vec = np.zeros(16)
        vec[:len(values)] = list(values.values())
        object.__setattr__(self, "system", system)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "parameters", values)
        object.__setattr__(self, "ndof", info["ndof"])
        object.__setattr__(self, "_vector", vec)
        object.__setattr__(self, "info", info)
        object.__setattr__(self, "_kept", None)
        # the input file's checks, with its messages (alpha > 0, 0 <= damping_ratio < 1, masses
        # > 0, 0 < mu <= 1/2, ...): the &model group read and validated by the program's reader
        _read_namelist([self._nml()], "Model")

    def _nml(self) -> str:
        """The &model group of this model, as an input file writes it."""
        head = _formula_nml(self.system, self.formula)[:-2] if self.formula else f"&model system = '{self.system}'"
        return head + "".join(f", {k} = {_nml_value(v)}" for k, v in self.parameters.items()) + " /"

    def __getattr__(self, key):
        try:
            return object.__getattribute__(self, "parameters")[key]
        except KeyError:
            raise AttributeError(f"system {self.system!r} has no parameter {key!r}") from None

    def __setattr__(self, key, value):
        raise AttributeError("Model is immutable: build a new one")

    def __eq__(self, other):
        return (isinstance(other, Model) and self.system == other.system and self.name == other.name
                and self.parameters == other.parameters)

    def __hash__(self):
        return hash((self.system, self.name, tuple(self.parameters.items())))

    def __reduce__(self):
        # a copy or a pickle is the same model built again, without the kept results
        return (_model_from, (self.system, dict(self.formula or {}), dict(self.parameters)))

    def __repr__(self):
        kw = ", ".join([f"{k}={v!r}" for k, v in (self.formula or {}).items()]
                       + [f"{k}={v!r}" for k, v in self.parameters.items()])
        return f"Model(system={self.system!r}{', ' if kw else ''}{kw})"

    def params(self) -> np.ndarray:
        """The parameter vector (16) the core takes, in the table's order."""
        return self._vector.copy()

    def _stores(self) -> int:
        """The handle of this model's kept results (opened on first use)."""
        if self._kept is None:
            object.__setattr__(self, "_kept", _Stores())
        return self._kept.handle

    def kept(self) -> dict:
        """What this model's calls have kept for later ones: equilibria searches, orbit
        families (each continued once, each orbit found once) and tube-seed set-ups."""
        h = self._kept.handle if self._kept is not None else 0
        n_eqs, n_fam, n_seeds = _lib().stores_counts(h)
        return {"equilibria": int(n_eqs), "families": int(n_fam), "seeds": int(n_seeds)}

    def forget(self) -> None:
        """Free what this model's calls have kept (later calls compute it again, the same bits)."""
        object.__setattr__(self, "_kept", None)

    def replace(self, **parameters) -> "Model":
        """A copy with some parameters (or formula variables) changed."""
        return Model(self.system, **{**(self.formula or {}), **self.parameters, **parameters})

    @classmethod
    def of(cls, res) -> "Model":
        """The model an output file was computed with (its /model group; a Result of load or
        an h5py group). Files written before /model@system existed are the rolling ball."""
        try:
            node = res["model"]          # a Result of load, or an h5py file
        except (KeyError, TypeError, AttributeError):
            node = res                   # the /model group itself
        attrs = dict(node.attrs)
        system = _decode(attrs.get("system", "rolling_ball"))
        if "formula" in attrs:            # a model written as a formula (docs/output.md)
            consts = [c.strip() for c in _decode(attrs.get("constants", "")).split(";") if c.strip()]
            if system == "expression":
                kw = {"hamiltonian": _decode(attrs["formula"]),
                      "coordinates": _decode(attrs.get("coordinates", "x y")).split(),
                      "momenta": _decode(attrs.get("momenta", "")).split() or None}
            else:
                kw = {"surface": "expression", "height": _decode(attrs["formula"])}
            # its parameters besides the formula's constants: g (a surface) and the dissipation
            kw.update({k: float(attrs[k]) for k in ("g", "damping_ratio", "rolling_resistance", "noise",
                                                    "temperature") if k in attrs and float(attrs[k]) != 0})
            return cls(system, constants=consts, **kw)
        names = model_info(system)["parameters"]
        return cls(system, **{k: float(attrs[k]) for k in names if k in attrs})


def _model_from(system, formula, parameters):
    return Model(system, **formula, **parameters)


class _Stores:
    """A Model's kept results in the core (tubes_study's open_stores), freed with the object."""
    __slots__ = ("handle", "__weakref__")
    live = None      # every open _Stores (a WeakSet): drop_all empties them after a Ctrl-C

    def __init__(self):
        import weakref  # noqa: PLC0415
        self.handle = 0
        self.handle = int(_lib().stores_open())
        if _Stores.live is None:
            _Stores.live = weakref.WeakSet()
        _Stores.live.add(self)

    @staticmethod
    def drop_all():
        """Empty every model's kept results (each gets a new, empty store)."""
        for s in list(_Stores.live or ()):
            h, s.handle = s.handle, 0
            if h:
                _lib().stores_close(h)
            s.handle = int(_lib().stores_open())

    def __del__(self):
        h, self.handle = self.handle, 0
        if h:
            try:
                _lib().stores_close(h)
            except Exception:       # the interpreter shutting down: the process frees it
                pass


def _sympy_text(e) -> str:
    """A formula as text: a string as it is, a SymPy expression printed with every float's
    shortest round-trip digits (SymPy's default printer keeps 15)."""
    if isinstance(e, str):
        return e
    from sympy.printing.str import StrPrinter  # noqa: PLC0415

    class _Exact(StrPrinter):
        def _print_Float(self, expr):
            return repr(float(expr))

    return _Exact().doprint(e)


def _formula(system, hamiltonian, coordinates, momenta, constants, surface, height) -> dict | None:
    """The formula variables of a model written as one (None for a library model)."""
    if system != "expression" and surface in (None, "fourwell"):
        if hamiltonian is not None or height is not None or constants is not None:
            raise ValueError(f"Model: hamiltonian, height and constants belong to system='expression' "
                             f"or surface='expression', not to system {system!r}")
        return None
    if system == "expression":
        if hamiltonian is None:
            raise ValueError("Model: system='expression' needs hamiltonian")
        if surface is not None or height is not None:
            raise ValueError("Model: surface and height belong to the rolling ball, not to system='expression'")
        f = {"hamiltonian": _sympy_text(hamiltonian)}
        if coordinates is not None:
            f["coordinates"] = [str(c) for c in coordinates]
        if momenta is not None:
            f["momenta"] = [str(c) for c in momenta]
    else:
        if system != "rolling_ball" or surface != "expression" or height is None:
            raise ValueError("Model: a formula's surface is system='rolling_ball', surface='expression', "
                             "height='...'")
        if hamiltonian is not None or coordinates is not None or momenta is not None:
            raise ValueError("Model: hamiltonian, coordinates and momenta belong to system='expression'")
        f = {"surface": "expression", "height": _sympy_text(height)}
    if constants:
        items = constants.items() if isinstance(constants, dict) else None
        f["constants"] = ([f"{k} = {_sympy_text(v) if not isinstance(v, (int, float)) else repr(v)}"
                           for k, v in items] if items is not None else [str(c) for c in constants])
    return f


def _quote(text: str) -> str:
    return "'" + str(text).replace("'", "''") + "'"


def _formula_nml(system: str, f: dict) -> str:
    """The &model group of a formula's model."""
    parts = [f"&model system = '{system}'"]
    for k, v in f.items():
        parts.append(f"{k} = " + (", ".join(_quote(x) for x in v) if isinstance(v, list) else _quote(v)))
    return ", ".join(parts) + " /"


def _codegen_env() -> None:
    """The code generator this process (and the program, python/tubes/_program.py) runs for a new
    formula or Taylor kernel: this Python, if it has SymPy (a pip-installed package's environment
    has it), and the package's codegen.py, unless the environment says otherwise. A Python without
    SymPy leaves TUBES_PYTHON to the program's search (src/io/tubes_expr.c, find_tool: the source
    tree's .venv)."""
    import importlib.util  # noqa: PLC0415
    import os  # noqa: PLC0415
    import sys  # noqa: PLC0415
    if importlib.util.find_spec("sympy") is not None:
        os.environ.setdefault("TUBES_PYTHON", sys.executable)
    os.environ.setdefault("TUBES_CODEGEN", os.path.join(os.path.dirname(os.path.abspath(__file__)), "codegen.py"))


def systems() -> list[str]:
    """The names of the built-in systems."""
    out, k = [], 1
    while True:
        stat, name = _lib().model_system(k)
        if stat < 0:
            return out
        out.append(_str(name))
        k += 1


def _str(b) -> str:
    return (b.decode() if isinstance(b, bytes) else str(b)).strip()


def model_info(system: str) -> dict:
    """The library's table entry of a system: ndof, parameters (name -> default, in order), their
    units and meanings (name -> text), the coordinates' units (``length_units``: "cm" for the
    ball, "1" for a dimensionless system), summary, and the scenes' defaults (saddle,
    saddle_near, section, gate, box)."""
    (stat, ndof, np_, names, units, docs, defaults, summary, saddle, near, sec_kind, sec_index, sec_value,
     sec_dir, sec_angle, gate, box, box_center, length_units) = _lib().model_info(system)
    if stat < 0:
        raise ValueError(f"unknown system {system!r}; the systems are: {', '.join(systems())}")
    names, units, docs = (b.decode() if isinstance(b, bytes) else str(b) for b in (names, units, docs))
    keys = [names[24 * k:24 * k + 24].strip() for k in range(np_)]
    params = {key: float(defaults[k]) for k, key in enumerate(keys)}
    return {"system": system, "ndof": int(ndof), "parameters": params,
            "parameter_units": {key: units[16 * k:16 * k + 16].strip() for k, key in enumerate(keys)},
            "parameter_docs": {key: docs[96 * k:96 * k + 96].strip() for k, key in enumerate(keys)},
            "length_units": _str(length_units), "summary": _str(summary),
            "saddle": _str(saddle), "saddle_near": np.array(near[:ndof]),
            "section": {"kind": _str(sec_kind), "index": int(sec_index), "value": float(sec_value),
                        "direction": int(sec_dir), "angle": float(sec_angle)},
            "gate": float(gate), "box": np.array(box[:ndof]), "box_center": np.array(box_center[:ndof])}


def _check(stat: int, where: str) -> None:
    if stat < 0:
        raise TubesError(stat, where)


def _check_rows(stat: int, where: str, call, *cols) -> None:
    """_check for a core call over the columns of cols (one row of the caller's each): on a failure
    of several, the first column that fails alone is named (its row index and values); the calls
    one by one are made only then."""
    if stat >= 0:
        return
    m = cols[0].shape[1]
    for k in range(m if m > 1 else 0):
        st = call(*(np.asfortranarray(c[:, k:k + 1]) for c in cols))[0]
        if st < 0:
            vals = "; ".join(", ".join(f"{v:.17g}" for v in c[:, k]) for c in cols)
            raise TubesError(st, f"{where}: row {k} of {m} ({vals})")
    raise TubesError(stat, where)


def _as_rows(x, n: int, who: str, name: str, what: str) -> np.ndarray:
    """x as a float64 copy of shape (m, n), one `what` (a state: n = 2N, or a position: n = N) per
    row: x is (m, n), or one of them (n,) (m = 1). Any other layout is refused, never reshaped: an
    (n, m) array, one per column as scipy's sol.y, would otherwise be read as other states. A
    square (n, n) array is taken as rows."""
    a = _args.floats(who, name, x)
    if a.ndim in (1, 2) and a.shape[-1] == n:
        return a.reshape(-1, n)
    msg = (f"{who}: {name} must have shape (m, {n}), one {what} of {n} components per row, or ({n},) "
           f"for one {what}: got shape {a.shape}")
    if a.ndim == 2 and a.shape[0] == n:
        y = "sol.y[:N]" if what == "position" else "sol.y"
        msg += (f"; its first axis has length {n}: for one {what} per column (scipy's {y} is "
                f"({'N' if what == 'position' else '2N'}, m)) pass the transpose, {name}.T ({y}.T)")
    raise ValueError(msg)


def _vec(x, n: int, name: str, who: str) -> np.ndarray:
    """x as one vector of n components: shape (n,) (or (1, n), one row); any other shape with n
    elements ((2, 2) for a state of 4) is refused, not flattened."""
    a = _args.floats(who, name, x)
    if a.shape not in ((n,), (1, n)):
        raise ValueError(f"{who}: {name} must have {n} components, one vector of shape ({n},): got shape {a.shape}")
    return a.reshape(-1)


_DEFAULT_MODEL: list = []


def _default_model() -> "Model":
    """The default Model() for the functions of a state or position (energy, vector_field,
    momentum, ...), built once: building one reads and checks a namelist (~0.5 ms, more than the
    call). Those functions keep nothing in it; the calls that keep results (equilibria, orbits,
    transition, ...) still start afresh with a new Model() when model is None."""
    if not _DEFAULT_MODEL:
        _DEFAULT_MODEL.append(Model())
    return _DEFAULT_MODEL[0]


def energy(state, model: Model | None = None) -> float:
    """H of a state (q, p) (2N components) on the conservative model; for the ball the energy
    per unit mass T + g H [(cm/s)^2] of (x, y, px, py)."""
    model = model or _default_model()
    n = 2 * model.ndof
    stat, e = _lib().energies(model.name, model.params(),
                              _vec(state, n, "state", "energy").reshape(n, 1, order="F"))
    _check(stat, "energy")
    return float(e[0])


def energies(states, model: Model | None = None) -> np.ndarray:
    """H of each row of states (m, 2N) (or of one state (2N,)), in one call to the core; returns
    (m,) (m = 1 for one state). States are rows: an array (2N, m) (scipy's sol.y) is refused
    (ValueError; pass sol.y.T)."""
    model = model or _default_model()
    n = 2 * model.ndof
    a = np.asfortranarray(_as_rows(states, n, "energies", "states", "state").T)
    stat, e = _lib().energies(model.name, model.params(), a)
    _check(stat, "energies")
    return np.asarray(e).copy()


def potentials(q, model: Model | None = None) -> np.ndarray:
    """V at each row of q (m, N) (or at one position (N,)) (natural systems: the ball's g H);
    returns (m,). Positions are rows: an array (N, m) is refused (ValueError; pass q.T)."""
    model = model or _default_model()
    n = model.ndof
    a = np.asfortranarray(_as_rows(q, n, "potentials", "q", "position").T)
    stat, v = _lib().potentials(model.name, model.params(), a)
    _check(stat, "potentials")
    return np.asarray(v).copy()


def shape_derivatives(q, model: Model | None = None):
    """Gradient (N, m) and Hessian (N, N, m) of the potential's shape at each row of q (m, N) (or
    at one position (N,): m = 1) (natural systems; the ball: of the surface's height H(x, y),
    V = g H). Positions are rows: an array (N, m) is refused (ValueError; pass q.T)."""
    model = model or _default_model()
    n = model.ndof
    a = np.asfortranarray(_as_rows(q, n, "shape_derivatives", "q", "position").T)
    stat, g, h = _lib().shape_derivs(model.name, model.params(), a)
    _check(stat, "shape_derivatives")
    return np.asarray(g).copy(), np.asarray(h).copy()


def vector_field(state, model: Model | None = None) -> np.ndarray:
    """Hamilton's equations dx/dt at a state (2N,) (damped for the ball with damping_ratio > 0),
    or at each row of states (m, 2N) in one call to the core (the model made once): returns the
    same shape. States are rows: an array (2N, m) (scipy's sol.y) is refused (ValueError; pass
    sol.y.T). A state the model refuses (NaN, blown up) raises TubesError naming, of rows, the
    first such row (its index and values)."""
    model = model or _default_model()
    n = 2 * model.ndof
    one = np.ndim(state) == 1
    a = np.asfortranarray(_as_rows(state, n, "vector_field", "state", "state").T)
    if a.shape[1] == 0:
        return np.zeros((0, n))
    lib, name, par = _lib(), model.name, model.params()
    stat, f = lib.vector_field(name, par, a)
    _check_rows(stat, "vector_field", lambda x: lib.vector_field(name, par, x), a)
    f = np.asarray(f).T.copy()
    return f[0] if one else f


def velocity(state, model: Model | None = None) -> np.ndarray:
    """dq/dt = dH/dp of a state on the conservative model (the ball: (dx/dt, dy/dt) [cm/s]); of
    each row of states (m, 2N): (m, N), in one call to the core."""
    model = model or _default_model()
    # a new Model only when there is damping to take off (making one reads a namelist: ~1 ms)
    cons = model.replace(damping_ratio=0.0) if model.parameters.get("damping_ratio", 0.0) != 0.0 else model
    return vector_field(state, cons)[..., :model.ndof]


def momentum(q, v, model: Model | None = None) -> np.ndarray:
    """Natural systems: the momenta of velocity v at q (the ball: p = (7/5) M v [cm/s]); q and v
    one position and velocity (N,) each, or rows (m, N) of them (one call to the core): returns
    the same shape."""
    model = model or _default_model()
    n = model.ndof
    one = np.ndim(q) == 1 and np.ndim(v) == 1
    a = _as_rows(q, n, "momentum", "q", "position")
    b = _as_rows(v, n, "momentum", "v", "velocity")
    if a.shape != b.shape:
        raise ValueError(f"momentum: q and v must have the same shape: got {np.shape(q)} and {np.shape(v)}")
    if a.shape[0] == 0:
        return np.zeros((0, n))
    lib, name, par = _lib(), model.name, model.params()
    a, b = np.asfortranarray(a.T), np.asfortranarray(b.T)
    stat, p = lib.momentum(name, par, a, b)
    _check_rows(stat, "momentum", lambda x, y: lib.momentum(name, par, x, y), a, b)
    p = np.asarray(p).T.copy()
    return p[0] if one else p


def _box(model: Model, box, box_center):
    info = model.info
    half = info["box"] if box is None else np.broadcast_to(np.asarray(box, float), (model.ndof,))
    centre = info["box_center"] if box_center is None else np.asarray(box_center, float)
    lo, hi = np.zeros(3), np.zeros(3)
    lo[:model.ndof] = centre - half
    hi[:model.ndof] = centre + half
    return lo, hi


def _record(h: int) -> dict:
    """A scene's result record (docs/development.md, "Scenes and their records") read and freed:
    {"code": its exit code, "lines": [(stream, text)] (1 stdout, 2 stderr), "data": {group: {name:
    array or list of str}}, "attrs": {group: {name: value}}}, arrays in the file's shapes."""
    lib = _lib()
    code, ni, nl = lib.record_sizes(h)
    out = {"code": int(code), "lines": [], "data": {}, "attrs": {}}
    try:
        for j in range(1, nl + 1):
            stream, text = lib.record_line(h, j)
            out["lines"].append((int(stream), _str(text).rstrip()))
        for k in range(1, ni + 1):
            kind, group, name, units, rank, dims, n = lib.record_item(h, k)
            group, name = _str(group).strip(), _str(name).strip()
            shape = tuple(int(d) for d in dims[:rank])
            if kind == 1:
                v = lib.record_reals(h, k, n).reshape(shape)
            elif kind == 2:
                v = lib.record_ints(h, k, n).reshape(shape)
            elif kind == 3:
                v = [_str(lib.record_string(h, k, j)).rstrip() for j in range(1, n + 1)]
            elif kind == 4:
                v = float(lib.record_reals(h, k, 1)[0])
            elif kind == 5:
                v = int(lib.record_long(h, k))
            else:
                v = _str(lib.record_string(h, k, 1)).rstrip()
            out["data" if kind <= 3 else "attrs"].setdefault(group, {})[name] = v
    finally:
        lib.record_free(h)
    return out


def equilibria(model: Model | None = None, box=None, n_grid: int | None = None, box_center=None) -> dict:
    """Equilibria with q in the search box (as the equilibria scene; any number of degrees of
    freedom N, 1 to 3). box: half-widths per coordinate, or one for all, > 0 [units of q: cm for
    the ball]; box_center: its centre (N values); n_grid: Newton starts per axis, 2 .. 2001 with
    n_grid^N <= 1e6. Defaults and ranges are &equilibria's, from the program's reader (the
    system's box, n_grid 41; docs/input.md).

    Returns a dict of arrays q (n, N), state (n, 2N), x, y (q1, q2; y NaN in 1 DOF), height,
    energy, morse_index (the index: eigenvalues with positive real part), rank1, degenerate,
    name, lambda, omega (rank-1 saddles; omega the lowest centre frequency, NaN in 1 DOF),
    omegas (n, N-1), grad_norm (Newton's residual: |grad V| for natural systems, else |dx/dt|),
    eigenvectors (n, 2N, 2N) (saddles; a degenerate one's zero modes come first, as zero columns):
    columns u (+lambda), s (-lambda), then per centre a_k, b_k, each of unit length: the real and
    imaginary parts of the +i omega_k eigenvector normalised separately, a basis of its plane
    (a_k + i r_k b_k is the eigenvector, r_k = |Im|/|Re|, not 1; docs/output.md, /saddle);
    frequencies (n, N): every point's centre frequencies, ascending, NaN-padded, and stable (all N
    pairs centres), as /equilibria's. What the box may hide (an equilibrium on its face, wells
    beyond it: docs/models.md, "The search box") is a RuntimeWarning with the program's note."""
    model = model or Model()
    for name, v in (("box", box), ("box_center", box_center)):
        if v is not None and np.size(v) not in ((1, model.ndof) if name == "box" else (model.ndof,)):
            raise ValueError(f"equilibria: {name} has {np.size(v)} values: allowed "
                             + ("1 (every coordinate) or " if name == "box" else "") + f"{model.ndof} (one per coordinate)")
    if n_grid is not None:   # its range in this API's words (as section_boundary's); its rule: the reader's
        n_grid = _in_range("equilibria", "equilibria", "n_grid", n_grid)
    eqg = {k: v for k, v in (("box", box), ("box_center", box_center), ("n_grid", n_grid)) if v is not None}
    # the input file's &equilibria: its defaults, ranges and messages (box > 0, n_grid^N <= 1e6)
    st = _read_namelist([model._nml()] + (["&equilibria " + ", ".join(f"{k} = {_nml_value(v)}" for k, v in eqg.items())
                                           + " /"] if eqg else []), "equilibria", {"model", "equilibria"})
    lo, hi, n_grid = st["lo"], st["hi"], st["n_grid"]
    # the program's equilibria scene (src/workflow/tubes_scene_equilibria.f90): its record's
    # /equilibria, its note on what the box may hide, its verdict
    rec = _scene("equilibria", st, model, method=0, saddle="", text1=model.name)
    if rec["code"]:
        raise TubesError(-1, "; ".join(t for s, t in rec["lines"] if s == 2))
    g = rec["data"]["equilibria"]
    nd = model.ndof
    rank1 = g["rank1"]
    out = {"q": g["state"][:, :nd].copy(), "state": g["state"], "x": g["x"], "y": g["y"], "height": g["height"],
           "energy": g["energy"], "morse_index": g["morse_index"], "rank1": rank1 == 1, "degenerate": rank1 == 2,
           "name": g["name"], "lambda": g["lambda"], "omega": g["omega"],
           "omegas": g["omegas"] if nd > 2 else g["omega"][:, None].copy() if nd > 1 else np.zeros((len(rank1), 0)),
           "grad_norm": g["grad_norm"], "eigenvectors": g["eigenvectors"], "frequencies": g["frequencies"],
           "stable": g["stable"] == 1}
    out.update(box=((hi - lo) / 2)[:nd].copy(), box_center=((hi + lo) / 2)[:nd].copy(), n_grid=int(n_grid))
    for s, t in rec["lines"]:
        if s == 2 and t.startswith("tubes: equilibria: note: "):
            import warnings  # noqa: PLC0415
            warnings.warn("equilibria: " + t[len("tubes: equilibria: note: "):], RuntimeWarning, stacklevel=2)
    return _table(out, "/equilibria", model)


def section_boundary(model: Model | None = None, dE: float = 0.0, saddle: str | None = None,
                     section: dict | None = None, m: int = 400, box=None, n_grid: int | None = None, *,
                     de: float | None = None) -> dict:
    """The energy surface's boundary on a section at E_e(saddle) + dE (docs/tubes.md,
    "Sections"; 2 degrees of freedom). dE: the excess energy, >= 0, in the model's energy units
    ((cm/s)^2 for the ball; default 0: the saddle's energy); ``de`` is its old name, deprecated.
    saddle: a rank-1 saddle's name (default the system's, else the one nearest its saddle_near);
    section: {"kind": "ray", "angle": deg, "p_theta_sign": +-1} or {"kind": "plane", "index": k,
    "value": c, "direction": +-1}, default the system's; m: points on the boundary (>= 2); box,
    n_grid: the equilibria's search box (as equilibria; n_grid's default and range &equilibria's,
    from the program's reader). Returns a dict s (m,), p_min, p_max
    (m,), s_min, s_max."""
    model = model or Model()
    if de is not None:
        import warnings  # noqa: PLC0415
        warnings.warn("section_boundary: de is deprecated, use dE (as the other functions)", DeprecationWarning,
                      stacklevel=2)
        dE = de
    _need_2dof(model, "section_boundary", "transition")
    dE = _args.real("section_boundary", "dE", dE, lo=0)
    m = _args.integer("section_boundary", "m", m, lo=2)
    # &equilibria n_grid: its range (the registry's, in this API's words: _in_range), then its default
    # and its rule n_grid^N <= 1e6 (the model's N) from the reader
    if n_grid is not None:
        n_grid = _in_range("section_boundary", "equilibria", "n_grid", n_grid)
    n_grid = _read_namelist([model._nml()] + ([f"&equilibria n_grid = {_nml_value(n_grid)} /"] if n_grid is not None
                                              else []), "section_boundary", {"model", "equilibria"})["n_grid"]
    info = model.info
    sec = dict(info["section"])
    if section:
        sec.update(section)
    if not sec["kind"]:
        raise ValueError(f"system {model.system!r} has no default section: give one")
    if box is not None:   # half-widths > 0, one or one per coordinate (the count: equilibria's check)
        box = [_args.real("section_boundary", "box", b, lo=0, lo_open=True) for b in np.ravel(np.asarray(box, dtype=object))]
    sad = saddle or info["saddle"]
    if not sad:
        eq = equilibria(model, box=box, n_grid=n_grid)
        near = info["saddle_near"]
        k = min((i for i in range(len(eq["name"])) if eq["rank1"][i]),
                key=lambda i: np.sum((eq["q"][i] - near) ** 2))
        sad = eq["name"][k]
    lo, hi = _box(model, box, None)
    who = "section_boundary"
    if sec["kind"] == "ray":
        kind, index, level = 1, 0, np.radians(_args.real(who, "section['angle']", sec.get("angle", 45.0)))
        dirn = _args.integer(who, "section['p_theta_sign']", sec.get("p_theta_sign", sec.get("direction", 1)),
                             lo=-1, hi=1)
    else:
        kind, index = 2, _args.integer(who, "section['index']", sec["index"], lo=0, hi=2 * model.ndof - 1)
        level = _args.real(who, "section['value']", sec["value"])
        dirn = _args.integer(who, "section['direction']", sec["direction"], lo=-1, hi=1)
    stat, smin, smax, s, pmin, pmax = _lib().section_boundary(
        model.name, model.params(), lo, hi, int(n_grid), sad, kind, index, level, dirn,
        float(dE), int(m))
    _check(stat, "section_boundary")
    return Table({"s": np.asarray(s).copy(), "p_min": np.asarray(pmin).copy(),
                  "p_max": np.asarray(pmax).copy(), "s_min": float(smin), "s_max": float(smax)})


# ---------------------------------------------------------------- scenes from Python

def _nml_value(v) -> str:
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return ".true." if v else ".false."
    if isinstance(v, (list, tuple, np.ndarray)):
        return ", ".join(_nml_value(x) for x in v)
    return repr(float(v)) if isinstance(v, float) else str(v)


_SETTINGS = ("stat", "msg", "system", "lo", "hi", "n_grid", "saddle", "use_near", "near", "n_segments",
             "sec_kind", "sec_index", "sec_level", "sec_dir", "tra_area_tol", "mc_t_max", "mc_gate",
             "pm_n_seeds", "pm_n_iter", "pm_t_max", "method", "h", "omega_bind", "solver", "int_max_iter",
             "orb_family", "expr_lib", "exp_rolling_resistance", "mc_n_samples", "mc_seed", "mc_de", "des",
             "ndes", "config")


def _read_namelist(lines: list[str], who: str, groups=None) -> dict:
    """Namelist groups read and validated exactly as the program reads an input file (the C
    lexer, the Fortran reader, the C validator: nml_load); a refusal raises ValueError with the
    program's messages, the temporary file's name and line taken off. groups: the groups the
    caller set (a message about another group, one that took its default from a refused value,
    as &flux de from &transition de, is left out when one about these is there)."""
    import os
    import tempfile
    fd, path = tempfile.mkstemp(suffix=".nml")
    try:
        with os.fdopen(fd, "w") as f:
            f.write("\n".join(lines) + "\n")
        out = _lib().read_input(path, _settings_size())
    finally:
        os.remove(path)
    st = dict(zip(_SETTINGS, out))
    if st["stat"] != 0:
        msgs = [re.sub(r"^\s*" + re.escape(path) + r"(:\d+)?:\s*", "", m)
                for m in _str(st["msg"]).splitlines() if m.strip()]
        if groups:
            own = [m for m in msgs if not m.startswith("&") or m.split(":")[0][1:] in groups]
            msgs = own or msgs
        msgs = list(dict.fromkeys(msgs))   # a message once
        raise ValueError(f"{who}: " + "\n".join(msgs or ["refused (no message)"]))
    return st


@functools.lru_cache(maxsize=None)
def _settings_size() -> int:
    """The size in bytes of the run's settings (tubes_config_t; read_input's config, the scenes' input)."""
    return int(_lib().settings_size())


_INT32 = 2**31 - 1   # the input file's integers (C int, Fortran default integer)


def _scene(name: str, st: dict, model, method=None, saddle=None, flags=(), text1: str = "", text2: str = ""):
    """The record of the program's scene `name` (src/workflow/tubes_scene_<name>.f90) on the settings st
    (_settings': their bytes, the saddle chosen) with the run's method (default &integrator's, resolved
    as the program resolves it) and the scene's own facts (python/tubes_f2py.f90 scene: flags, text1,
    text2)."""
    f = np.zeros(4, dtype=np.int32)
    f[:len(flags)] = [int(x) for x in flags]
    m = _method(int(st["method"]), model) if method is None else method
    return _record(_lib().scene(name, st["config"], st["saddle"] if saddle is None else saddle, m, f, text1, text2,
                                model._stores()))


def _settings(model: Model, saddle=None, saddle_near=None, section=None, who: str = "tubes", **groups) -> dict:
    """The settings of a scene call as the program would use them: the model, the keywords given
    (group -> {variable: value}) written as a namelist and read by the program's own reader
    (src/io/tubes_nml.f90), so that every default, every system default and every range check
    comes from the one place the input file's come from. who: the calling function, the head of
    every refusal's message."""
    lines = [model._nml()]
    for g, kv in groups.items():
        for k, v in (kv or {}).items():
            if isinstance(v, (int, np.integer)) and not isinstance(v, bool) and abs(int(v)) > _INT32:
                raise ValueError(f"{who}: {k} = {v} is out of range: the input file's integers are 32-bit, "
                                 f"allowed |{k}| <= {_INT32} (docs/input.md, &{g})")
    orb = dict(groups.pop("orbits", {}))
    if saddle is not None and saddle_near is not None:
        raise ValueError("give saddle or saddle_near, not both")
    if saddle is not None:
        orb["saddle"] = str(saddle)
    if saddle_near is not None:
        orb["saddle_near"] = _args.reals(who, "saddle_near", saddle_near)
    if orb:
        groups["orbits"] = orb
    if section:
        sec = dict(section)
        groups["section"] = sec
    for g, kv in groups.items():
        if kv:
            lines.append(f"&{g} " + ", ".join(f"{k} = {_nml_value(v)}" for k, v in kv.items()) + " /")
    given = {"model"} | {g for g, kv in groups.items() if kv}
    st = _read_namelist(lines, who, given)
    st["saddle"] = _str(st["saddle"])
    if st["use_near"] or who not in ("equilibria", "synthetic_experiment"):
        # the program's rule (src/workflow/tubes_setup.f90 run_saddle, choose_saddle): by name (the system's
        # default too: the ball with beta = 0 has none), or the nearest to saddle_near; the flux
        # takes a degenerate saddle (D<k>) too
        code, chosen, _e, msg = _lib().saddle_of_run(
            model.name, model.params(), st["lo"], st["hi"], int(st["n_grid"]), model._stores(), st["saddle"],
            int(bool(st["use_near"])), np.asarray(st["near"], dtype=float), int(who == "flux"), model.system,
            int(saddle is None and not st["use_near"]))
        if code < 0:                     # the equilibria search failed: the program's message
            err = TubesError(int(code), who)
            err.args = (f"{who}: {_str(msg)}",)
            raise err
        if code:
            raise ValueError(f"{who}: {_str(msg)}")
        st["saddle"] = _str(chosen)
        # the scene's excess energies against what the energy resolves at the saddle (the program's
        # check, src/workflow/tubes_setup.f90 de_unresolved)
        group = _DE_GROUPS.get(who)
        given = (groups.get(group) or {}).get("de") if group else None
        if given is not None:
            k, dmsg = _lib().de_unresolved(np.atleast_1d(np.asarray(given, dtype=float)), group, st["saddle"], float(_e))
            if k:
                raise ValueError(f"{who}: {_str(dmsg)}")
    return st


# the group whose excess energies each scene function takes (_settings' resolution check)
_DE_GROUPS = {"orbit_family": "orbits", "tube_cut": "tubes", "transition": "transition", "monte_carlo": "montecarlo",
              "poincare": "sections", "flux": "flux"}


def _study(model, st):
    return (model.name, model.params(), st["lo"], st["hi"], int(st["n_grid"]), st["saddle"])


_TAYLOR_OK = {}   # (model name, parameters, method) -> (the method resolved, why) (_method)

# integrate()'s kept integrators, per thread (one thread at a time per integrator): (model, method,
# options) -> handle. Making the model and finding its Taylor kernel cost ~30 us a call; a kept
# integrator restarted at t = 0 gives the same bits as a new one for the methods below (their state
# is the integrator's own, reset by restart; tests/test_percall.py), not for a noisy model (its
# noise stream).
_KEPT = threading.local()
_KEPT_METHODS = (METHODS["taylor"], METHODS["dop853"])
_KEPT_MAX = 16


def _kept_integrator(model, code: int, opts: tuple) -> int:
    """The kept integrator of integrate() for the model and options, opened on first use (0: none
    for this method or model, integrate() makes its own)."""
    par = model.parameters
    if code not in _KEPT_METHODS or par.get("noise", 0.0) != 0 or par.get("temperature", 0.0) != 0:
        return 0
    cache = getattr(_KEPT, "cache", None)
    if cache is None:
        cache = _KEPT.cache = {}
    key = (model.name, model._vector.tobytes(), code, opts)
    handle = cache.get(key)
    if handle is None:
        h, stat = _lib().integrator_open(model.name, model.params(), code, *opts)
        if stat < 0:
            return 0                         # integrate() makes its own and says why
        if len(cache) >= _KEPT_MAX:          # the oldest out
            _lib().integrator_close(cache.pop(next(iter(cache))))
        handle = cache[key] = int(h)
    return handle


def _integ(st, model):
    return (_method(int(st["method"]), model), float(st["h"]), float(st["omega_bind"]),
            int(st["solver"]), int(st["int_max_iter"]))


def _method(code: int, model, eps: float = 1e-12) -> int:
    """A method code as the program resolves it (src/workflow/tubes_setup.f90 method_resolved):
    'auto' becomes DOP853 throughout where the model's Taylor kernel cannot be had (no C compiler or
    SymPy), with a warning naming the reason; 'taylor' without it is refused (ValueError), as the
    program refuses it (docs/integrators-taylor.md). The answer is kept per model."""
    if code not in (METHODS["auto"], METHODS["taylor"]):
        return code
    key = (model.name, tuple(model.params()), code)
    got = _TAYLOR_OK.get(key)
    if got is None:
        m, why = _lib().method_choice(code, model.name, model.params(), float(eps))
        got = _TAYLOR_OK[key] = (int(m), _str(why).strip())
        if got[0] not in (0, code):
            import warnings
            warnings.warn(f"method 'auto': DOP853 throughout (no Taylor kernel for this model: {got[1]})",
                          stacklevel=3)
    if got[0] == 0:
        raise ValueError(f"method 'taylor': no Taylor kernel for system {model.system!r}: {got[1]}")
    return got[0]


def _section_args(st):
    if st["sec_kind"] == 0:
        raise ValueError("this system has no default section: give section={'kind': 'plane', "
                         "'index': k, 'value': c, 'direction': +-1}")
    return int(st["sec_kind"]), int(st["sec_index"]), float(st["sec_level"]), int(st["sec_dir"])


def _need_2dof(model: Model, who: str, scene: str, plane: bool = True) -> None:
    """Whether the scene (the program's name: tubes, transition, montecarlo, sections) applies to
    the model: the program's rule (src/workflow/tubes_setup.f90 scene_refused): the scenes on a
    section's region need 2 degrees of freedom, the tubes 2 or 3 with a plane (plane False: the
    ball's ray)."""
    code, msg = _lib().scene_check(scene, model.ndof, int(plane), model.system)
    if code:
        raise ValueError(f"{who}: {_str(msg)}")


def _default_de(model: Model, who: str, group: str) -> None:
    """The scenes' default excess energies (&<group> de) are the paper's, in the ball's units: the
    program's rule (src/workflow/tubes_setup.f90 default_refused): any model but the library's
    rolling ball must give dE."""
    k, msg = _lib().default_refused(model.name, group, model.system)
    if k:
        raise ValueError(f"{who}: {_str(msg)}")


def _scalar_de(dE, who: str):
    """One excess energy as a float (None stays None); the range check is the reader's."""
    if dE is None:
        return None
    if np.ndim(dE) != 0:
        raise ValueError(f"{who}: dE must be one number (got shape {np.shape(dE)})")
    return _args.real(who, "dE", dE)


def _de_list(dE, who: str):
    """Excess energies as a list of floats (None stays None); the range check is the reader's."""
    if dE is None:
        return None
    if np.size(dE) == 0:
        raise ValueError(f"{who}: dE is empty: give at least one excess energy > 0")
    return _args.reals(who, "dE", dE)


def orbit_family(model: Model | None = None, dE=None, saddle=None, saddle_near=None,
                 integrator: dict | None = None, equilibria: dict | None = None, check: bool = True,
                 **orbits) -> dict:
    """The Lyapunov orbits of a rank-1 saddle at the excess energies dE (as the orbits scene,
    docs/orbits.md). dE: excess energies above the saddle, > 0 and increasing, in the model's
    energy units ((cm/s)^2 for the ball); default &orbits de (1, 10, 100 (cm/s)^2): the rolling
    ball only, required for any other model. Where an orbit did not converge (past the family's
    end, or Newton failed) its quantities are NaN (the output file's 0) and converged is False;
    residual and iterations stay (residual NaN where no iteration was made). Returns a
    dict of arrays dE, energy, period, action, mu_unstable, mu_stable,
    mu_trivial and mu_trivial_imag (n, 2), stability_index, monodromy (n, 2N, 2N), residual,
    closure, iterations, min_eq_distance, converged, state0 (n, 2N) (docs/output.md, /orbits),
    and end_dE (the family's estimated end, or None); floquet_index and floquet_index_imag (n, N-1)
    and bifurcations (a dict of /orbits/bifurcations: kind, after, converged, dE, bracket, energy,
    period, floquet_index(_imag), state0, tangent, tol; docs/orbits.md "Bifurcations"),
    family_name. Keywords: saddle or saddle_near, and &orbits' method, n_segments, tol, rtol, atol,
    max_iter, n_samples, family (the k-th centre mode's family in 3 DOF, or 'lyapunov', 'vertical',
    'halo_north' / 'halo_south', 'axial': docs/orbits.md "Branch switching"; 'branch:K', the family
    off the K-th bifurcation); guess=[2N reals], period=T (a family through a guess: docs/orbits.md
    "Orbits from a guess"; dE may then be of any sign); jacobi=[C, ...] or
    periods=[T, ...] instead of dE (&orbits jacobi, periods, periods for any family but 'branch:K',
    docs/orbits.md "Orbits by Jacobi constant or period": one of dE, jacobi, periods; the orbits are
    those at the dE the program's Fortran finds for them; the Table adds jacobi (C of each orbit,
    a model with a Jacobi constant), parameter and requested_jacobi or requested_period; a period
    the family does not reach: TubesError EPASTEND); integrator: &integrator's method and its options as a dict, e.g. {"method":
    "arkode_erk8"} (default the input file's, "auto": Taylor for the state, DOP853 for the
    variational equations). Each orbit is the continuation to its own energy alone: the same
    bits whatever else dE holds, and the same as the program's orbits scene and tube cuts.

    check (default True): raise where the orbits scene exits non-zero: DisagreementError where an
    orbit's integration is too coarse for it (closure / mu_unstable above 1e-8 of the state;
    src/workflow/tubes_verdicts.f90, the scene's check; exit 2), TubesError where an orbit was
    not found (past the family's end: EPASTEND; else ENOCONV) or a bifurcation's bisection failed
    (exit 4); the Table is the error's partial. check=False returns it, the messages of the
    first kind in ``verdicts``."""
    model = model or Model()
    check = _args.flag("orbit_family", "check", check)
    # a family from a guess (guess=[2N reals], period=T) and 'branch:K' (docs/orbits.md, "Orbits from a
    # guess"): the program's &orbits guess, period, family, read and checked by its reader
    # the orbits by Jacobi constant or by period (docs/orbits.md, "Orbits by Jacobi constant or period"):
    # the program's &orbits jacobi, periods, read and checked by its reader, located by its Fortran
    byp = {k: orbits.pop(k) for k in ("jacobi", "periods") if orbits.get(k) is not None}
    for k in ("jacobi", "periods"):
        orbits.pop(k, None)
    named = (["dE"] if dE is not None else []) + list(byp)
    if len(named) > 1:
        raise ValueError(f"orbit_family: {named[0]} and {named[1]} are both given: the orbits are asked for by one "
                         "parameter (allowed: exactly one of dE, jacobi (the Jacobi constant C), periods)")
    for k, v in byp.items():
        if np.size(v) == 0:
            raise ValueError(f"orbit_family: {k} is empty: give at least one value")
        byp[k] = _args.reals("orbit_family", k, v)
    de = _de_list(dE, "orbit_family")
    if de is None and not byp:
        _default_de(model, "orbit_family", "orbits")
    orb = dict(orbits, **byp) if de is None else dict(orbits, de=de)
    st = _settings(model, saddle, saddle_near, who="orbit_family", orbits=orb, integrator=integrator,
                   equilibria=equilibria)
    rec = _scene("orbits", st, model, flags=(str(model.info.get("length_units", "1")) == "cm",
                                             bool(_dissipation(model))))
    said = [t for s, t in rec["lines"] if s == 2]
    msg = "; ".join(t.removeprefix("tubes: orbits: ") for t in said)
    if "orbits" not in rec["data"]:           # refused or failed before any orbit
        if rec["code"] == 1:
            raise ValueError(f"orbit_family: {msg}")
        stat = re.search(r"\(status (-\d+)\)$", said[-1]) if said else None   # the core's status, if it said one
        raise TubesError(int(stat.group(1)) if stat else _lib().status_code("EPASTEND" if "not reached" in msg
                                                                             else "ENOCONV"), f"orbit_family: {msg}")
    g, a = rec["data"]["orbits"], rec["attrs"]["orbits"]
    de = g["dE"]
    end_de = a.get("family_end_dE")
    out = {"dE": de, "energy": g["energy"], "period": g["period"], "action": g["action"],
           "mu_unstable": g["mu_unstable"], "mu_stable": g["mu_stable"], "mu_trivial": g["mu_trivial"],
           "mu_trivial_imag": g["mu_trivial_imag"], "stability_index": g["stability_index"],
           "monodromy": g["monodromy"], "residual": g["residual"], "closure": g["closure"],
           "iterations": g["iterations"], "min_eq_distance": g["min_eq_distance"],
           "converged": g["converged"] == 1, "state0": g["state0"],
           "end_dE": end_de if end_de is not None and end_de > 0 else None, "saddle": a["saddle"],
           "family": a["family"], "method": a["method"], "n_segments": a["n_segments"], "tol": a["tol"]}
    bad = ~out["converged"]
    for k in ("period", "action", "mu_unstable", "mu_stable", "mu_trivial", "mu_trivial_imag", "stability_index",
              "monodromy", "closure", "min_eq_distance", "state0"):
        out[k][bad] = np.nan          # no orbit: not a period of 0
    out["residual"][bad & (out["iterations"] == 0)] = np.nan
    # the Floquet indices and the bifurcations between the orbits (/orbits/bifurcations)
    out["floquet_index"], out["floquet_index_imag"] = g["floquet_index"], g["floquet_index_imag"]
    out["bifurcations"] = dict(rec["data"]["orbits/bifurcations"], tol=rec["attrs"]["orbits/bifurcations"]["tol"])
    out["family_name"] = a["family_name"]
    if "jacobi" in g:                          # C of each orbit, a model with a Jacobi constant
        out["jacobi"] = g["jacobi"]
    if "parameter" in a:
        out["parameter"] = a["parameter"]
        out["requested_jacobi" if a["parameter"] == "jacobi" else "requested_period"] = \
            g["requested_jacobi" if a["parameter"] == "jacobi" else "requested_period"]
    # the scene's check of the integration's accuracy (src/workflow/tubes_verdicts.f90 orbit_coarse)
    out["verdicts"] = [t for t in said if "the integration is too coarse" in t]
    t = _table(out, "/orbits", model)
    if not check:
        return t
    if t["verdicts"]:
        raise DisagreementError("; ".join(t["verdicts"]) + " (check=False returns the Table, its verdicts in "
                                "'verdicts')", t)
    if rec["code"] == 1:                      # a guess that did not converge, a family the modes do not define
        raise ValueError(f"orbit_family: {msg}")
    bad = np.flatnonzero(~t["converged"])
    if bad.size:
        past = t["end_dE"] is not None and de[bad[0]] >= t["end_dE"] * (1 - 1e-6)
        err = TubesError(_lib().status_code("EPASTEND" if past else "ENOCONV"),
                         "orbit_family: no orbit at dE = " + ", ".join(f"{d:g}" for d in de[bad])
                         + " (NaN there; the Table in partial; check=False returns it); at dE = " + f"{de[bad[0]]:g}")
        err.partial = t
        raise err
    nb = np.flatnonzero(t["bifurcations"]["converged"] == 0)
    if nb.size:
        err = TubesError(_lib().status_code("ENOCONV"), "orbit_family: the corrector failed inside the bisection's "
                         f"bracket of {nb.size} bifurcation(s), the first near dE = {t['bifurcations']['dE'][nb[0]]:.12g} "
                         "(the Table in partial; check=False returns it)")
        err.partial = t
        raise err
    return t


def flux(model: Model | None = None, dE=None, saddle=None, saddle_near=None,
         n_samples=None, seed=None, t_max=None, gate=None, tol=None, order=None, section: dict | None = None,
         integrator: dict | None = None, equilibria: dict | None = None, check: bool = True,
         **cut_options) -> Table:
    """The flux of trajectories through a rank-1 saddle's bottleneck (as the flux scene,
    docs/theory.md "Flux in N degrees of freedom"; natural systems, 2 or 3 DOF): dict of arrays
    dE, flux_sampled, flux_sampled_err, flux_leading_order, n_inside, n_reacting, n_recrossing,
    n_undecided; with order = K (a model written as a formula) also flux_normal_form,
    flux_normal_form_change and normal_form (dict: lambda, omegas, coefficients, powers (n, N),
    symplectic_error, residual, imaginary, smallest_divisor), the scene's numbers. With a plane
    section (3 DOF; {'kind': 'plane', 'index': k, 'value': c, 'direction': +-1}) also
    section_volume(_err), p_trans_section(_err), p_trans_theory (flux / volume), and with order
    (&flux n_cut > 0) tube_cut: the stable tube's cut with the section per dE (the scene's
    /flux/tube_cut: section, states, time, status, volume, volume_half, volume_extrapolated,
    seed_energy_error, misclassified, misclassified_pl, unresolved, p_trans_tube, and the section's
    points, weight, outcome, inside, inside_pl). Keywords as &flux (defaults from the program's
    reader; n_cut and cut_eps too). dE: excess energies above the saddle, > 0 and increasing, in
    the model's energy units; default &flux de (the &transition list, (cm/s)^2): the rolling ball
    only, required for any other model.

    The numbers, messages and verdicts are the record of the program's own flux scene
    (src/workflow/tubes_scene_flux.f90, one Fortran call). A model whose H is not quadratic in the
    momenta is not sampled (flux_sampled NaN): with order, the normal form's flux alone, as ./tubes.
    A sampling that fails raises TubesError with its status; a refused order or normal form
    ValueError. The scene's checks (src/workflow/tubes_verdicts.f90): a flux
    below the smallest double (NaN there), more than 1 % undecided points, the normal form without a
    flux or more than 5 standard errors from the sampled flux, flux / volume (the normal form's
    where its change from order K - 2 is within 10 %, else the sampled) above 1 or more than 5
    standard errors from the section's Monte Carlo fraction, the tube cut's volume or misclassified
    points beyond its resolution. Where ./tubes exits 2 on one of them this raises
    DisagreementError (its ``partial`` the Table); check=False returns the Table with the messages
    in ``verdicts`` (empty where every check holds)."""
    model = model or Model()
    de = _de_list(dE, "flux")
    if de is None:
        _default_de(model, "flux", "flux")
    fl = {k: v for k, v in (("n_samples", n_samples), ("seed", seed), ("t_max", t_max), ("gate", gate),
                             ("tol", tol), ("order", order)) if v is not None}
    fl.update(cut_options)
    if de is not None:
        fl["de"] = de
    st = _settings(model, saddle, saddle_near, section=section, who="flux", flux=fl, integrator=integrator,
                   equilibria=equilibria)
    de = np.array(st["des"][:int(st["ndes"][4]), 4])
    if not model.info or model.info.get("ndof", 2) < 2:
        raise ValueError("flux: the model needs 2 or 3 degrees of freedom")
    if section is not None and (model.ndof != 3 or int(st["sec_kind"]) != 2):
        raise ValueError("flux: section: the transition fraction on a section is for a plane section in 3 "
                         "degrees of freedom (2 DOF: tubes.transition)")
    # the program's flux scene (src/workflow/tubes_scene_flux.f90): its record's /flux, its verdicts
    rec = _scene("flux", st, model, text1="flux")
    verdicts = [t for s, t in rec["lines"] if s == 2]
    g, a = rec["data"]["flux"], rec["attrs"]["flux"]
    if rec["code"]:
        sampled = not any(t.startswith("  (not sampled:") for s, t in rec["lines"] if s == 1)
        failed = [int(s) for s in g["status"] if s < 0 and sampled]
        if failed:       # the sampling failed (as the program's 'failed: ... (status N)')
            raise TubesError(failed[0], "flux: " + "; ".join(verdicts))
        if rec["code"] == 1:      # a refused request (the normal form's order, a model without a formula)
            raise ValueError("; ".join(verdicts))
    out = {k: g[k] for k in ("dE", "flux_sampled", "flux_sampled_err", "flux_leading_order", "n_inside",
                             "n_reacting", "n_recrossing", "n_undecided")}
    if "flux_normal_form" in g:
        out.update(flux_normal_form=g["flux_normal_form"], flux_normal_form_change=g["flux_normal_form_change"])
        if a["normal_form_status"] != 0:
            raise ValueError(f"flux: {a['normal_form_message']}")
        nf, na = rec["data"].get("flux/normal_form", {}), rec["attrs"].get("flux/normal_form", {})
        if nf:
            powers = [nf[k] for k in ("power_I1", "power_J2", "power_J3") if k in nf]
            out["normal_form"] = {"lambda": na["lambda"], "omegas": nf["omegas"], "coefficients": nf["coefficients"],
                                  "powers": np.stack(powers, axis=1),
                                  **{k: na[k] for k in ("symplectic_error", "residual", "imaginary", "smallest_divisor")}}
    sec = rec["data"].get("flux/section")
    if section is not None and sec:
        out.update({"section_volume": sec["volume"], "section_volume_err": sec["volume_err"],
                    "p_trans_section": sec["p_trans"], "p_trans_section_err": sec["p_trans_err"],
                    "p_trans_theory": sec["p_trans_theory"]})
    cut = rec["data"].get("flux/tube_cut")
    if section is not None and cut:
        ca = rec["attrs"]["flux/tube_cut"]
        out["tube_cut"] = dict(cut, axes=ca["axes"], n_cut=ca["n_cut"])
    out["verdicts"] = verdicts
    out = _table(out, "/flux", model)
    if verdicts and _args.flag("flux", "check", check):
        raise DisagreementError("; ".join(verdicts) + " (check=False returns the result, its "
                                "verdicts in 'verdicts')", out)
    return out


def _taylor_at_saddle(model, st, order, who):
    """The Taylor expansion (exponents (2N, n), coefficients, the saddle's state z_s) of the formula
    at the saddle of the settings, from the spec embedded in its library (the one the program reads)."""
    import ctypes

    from . import codegen
    path = _str(st["expr_lib"])
    if not path:
        raise ValueError(f"{who}: order = {order}: the normal form needs the model written as a formula "
                         "(system='expression'): its Taylor expansion comes from the formula")
    so = ctypes.CDLL(path)
    spec = ctypes.string_at(ctypes.addressof(ctypes.c_char.in_dll(so, "tubes_expr_text"))).decode()
    lo, hi = np.asarray(st["lo"], float), np.asarray(st["hi"], float)
    nd = model.ndof
    eq = equilibria(model, box=list((hi - lo)[:nd] / 2), n_grid=int(st["n_grid"]), box_center=list((hi + lo)[:nd] / 2))
    k = eq["name"].index(_str(st["saddle"]))
    terms = codegen.taylor(codegen.read_spec(spec.splitlines()), [float(v) for v in eq["state"][k]], order)
    expo = np.asfortranarray(np.array([m for m, _ in terms], dtype=np.int32).T)
    coef = np.array([c for _, c in terms], dtype=np.float64)
    return expo, coef, np.asarray(eq["state"][k], dtype=float)


def normal_form_map(model: Model, points, order: int = 8, to: str = "model", saddle=None, saddle_near=None,
                    equilibria: dict | None = None) -> dict:
    """Points through the Birkhoff normal form's coordinate change at a saddle (docs/theory.md, "The
    normal form"; a model written as a formula, 2 or 3 DOF). to = 'model': points (m, 2N) are real
    normal-form coordinates (x_1..x_N, y_1..y_N: x_1 unstable, y_1 stable, (x_k, y_k) the k-th
    centre, J_k = (x_k^2 + y_k^2)/2), returned as the model's states z (m, 2N); to = 'normal_form':
    the reverse. Returns dict points (mapped), round_trip (m,) the max-norm error of mapping back
    (the truncated series' own check: it grows with the distance from the saddle), saddle_state."""
    if to not in ("model", "normal_form"):
        raise ValueError("normal_form_map: to = 'model' or 'normal_form'")
    order = _args.integer("normal_form_map", "order", order)
    st = _settings(model, saddle, saddle_near, who="normal_form_map", equilibria=equilibria,
                   flux={"order": order})
    expo, coef, zs = _taylor_at_saddle(model, st, order, "normal_form_map")
    nd = model.ndof
    pts = _as_rows(points, 2 * nd, "normal_form_map", "points", "point")
    if to == "normal_form":
        pts = pts - zs
    stat, out, rt, msg = _lib().nf_map(int(order), expo, coef, 1 if to == "model" else 0,
                                       np.asfortranarray(pts.T), nd=nd)
    if stat != 0:
        raise ValueError(f"normal_form_map: {_str(msg)}")
    mapped = out.T.copy()
    if to == "model":
        mapped += zs
    return Table({"points": mapped, "round_trip": rt.copy(), "saddle_state": zs})


TUBE_KINDS = {"stable": -1, "unstable": 1}   # the tubes scene's kind (src/io/tubes_scenes.c)


def tube_cut(model: Model | None = None, dE: float | None = None, kind: str = "stable", saddle=None,
             saddle_near=None, section=None, integrator: dict | None = None, equilibria: dict | None = None,
             check_eps: bool = True, **options) -> Table:
    """The cut of the saddle's stable (or unstable) tube at dE with the section (as the tubes
    scene, docs/tubes.md; 2 degrees of freedom, or 3 with a plane section: "Tubes of halo orbits").

    dE: the excess energy above the saddle, > 0, in the model's energy units ((cm/s)^2 for the
    ball); required (the scene's default list, &tubes de = 10, 100, is the ball's and a list).
    kind: "stable" (default) or "unstable". saddle (a rank-1 saddle's name) or saddle_near (a
    configuration point; the saddle nearest to it), default the system's; section: a dict as in
    section_boundary, default the system's; integrator: &integrator's keywords as a dict;
    equilibria: &equilibria's (box, box_center, n_grid). options: &tubes' eps, area_tol, t_max,
    n_init, n_max and &orbits' method, n_segments, tol, rtol, atol, family (the orbit's family, as
    orbit_family's: with 3 degrees of freedom 'halo_north', 'halo_south' too); defaults and ranges
    from the program's reader (docs/input.md).

    Returns a tubes.Table: dE, r, p_r (the section's s, p_s), tau [time units], time, state (n, 2N),
    area, area_polygon, action, period, kind, eps, converged, history_n and history_area (the
    points and area after each refinement round), and, as the scene, area_eps10 and
    area_eps_change: the area of the cut repeated with eps/10 and its change (the check that the
    start's distance eps from the orbit does not matter; check_eps=False skips it, half the
    cost). With 3 degrees of freedom also section (n, 4) (the plane's pairs (q_a, p_a, q_b, p_b):
    r, p_r are the first), axes, floquet_vector, sigma, family and the plane's section_index,
    section_value, section_direction, as the scene's /tubes group (docs/output.md); area is then the
    loop integral of p . dq over the cut."""
    model = model or Model()
    if kind not in TUBE_KINDS:
        raise ValueError(f"tube_cut: kind = {kind!r} is not allowed: allowed {', '.join(map(repr, TUBE_KINDS))}")
    # 3 DOF: the tubes of any family on a plane (docs/tubes.md, "Tubes of halo orbits")
    _need_2dof(model, "tube_cut", "tubes", (section or {}).get("kind", "plane") == "plane")
    if dE is None:
        raise ValueError("tube_cut: give dE, the excess energy above the saddle (> 0, in the model's energy units)")
    orb = {k: options.pop(k) for k in list(options) if k in ("method", "n_segments", "tol", "rtol", "atol", "family")}
    st = _settings(model, saddle, saddle_near, section=section, who="tube_cut", orbits=orb,
                   tubes=dict(options, de=[_scalar_de(dE, "tube_cut")], kind=kind), integrator=integrator,
                   equilibria=equilibria)
    de = float(st["des"][0, 1])
    check = _args.flag("tube_cut", "check_eps", check_eps)
    # the program's tubes scene (src/workflow/tubes_scene_tubes.f90) at this one energy and kind,
    # the conservative model's cut (a dissipative model's regions are transition_region's)
    _section_args(st)
    rec = _scene("tubes", st, model, flags=(check,))
    errs = [t for s, t in rec["lines"] if s == 2]
    if rec["code"]:
        codes = [int(c) for c in re.findall(r"\(status (-?\d+)\)", " ".join(errs))]
        if not codes and "past the end" in " ".join(errs):
            codes = [int(_lib().status_code("EPASTEND"))]
        raise TubesError(codes[0] if codes else -1, f"tube_cut(dE = {de}): " + "; ".join(errs))
    g, a = rec["data"][f"tubes/{kind}_000"], rec["attrs"][f"tubes/{kind}_000"]
    out = {"dE": a["dE"], "r": g["r"], "p_r": g["p_r"], "tau": g["tau"], "time": g["time"], "state": g["state"],
           "area": a["area"], "area_polygon": a["area_polygon"], "action": a["action"], "period": a["period"],
           "kind": a["kind"], "eps": a["eps"], "converged": a["converged"],
           "history_n": g.get("history_n", np.zeros(0, dtype=np.int32)).astype(np.int32),
           "history_area": g.get("history_area", np.zeros(0))}
    if model.ndof > 2:   # as the scene's 3-DOF /tubes/<kind>_<k> (docs/output.md)
        out.update(section=g["section"], axes=a["axes"], floquet_vector=g["floquet_vector"], sigma=a["sigma"],
                   family=a["family"], section_index=a["section_index"], section_value=a["section_value"],
                   section_direction=a["section_direction"])
    if check:
        out.update(area_eps10=a["area_eps10"], area_eps_change=a["area_eps_change"])
    return _table(out, f"/tubes/{kind}_0", model)


def _dissipation(model: Model) -> dict:
    """The model's dissipation as the scenes record it (src/workflow/tubes_setup.f90 model_dissipation,
    the program's): {} for a conservative model, else dissipation (the law: viscous, rolling, noise,
    joined by '+') and damping_ratio, rolling_resistance, noise, temperature where they act
    (docs/dissipation.md)."""
    law, _text, v, stat = _lib().dissipation_of(model.name, model.params())
    law = _str(law)
    if stat < 0 and law:
        raise ValueError(f"&model: the model's dissipation ({law}) is defined by its lowest well's slow mode "
                         f"omega_1, which failed: {status_message(int(stat))} (docs/dissipation.md#other-models)")
    if not law:
        return {}
    names = ("damping_ratio", "rolling_resistance", "noise", "temperature")
    return {"dissipation": law, **{k: float(x) for k, x in zip(names, v[:4]) if x > 0}}


def _recorded_dissipation(attrs: dict) -> dict:
    """The dissipation's attributes a scene's record gave its group (src/workflow/tubes_setup.f90
    dissipation_attrs), as _dissipation returns them."""
    names = ("dissipation", "damping_ratio", "rolling_resistance", "noise", "temperature")
    return {k: attrs[k] for k in names if k in attrs}


def conservative(model: Model) -> Model:
    """The model without its dissipation (damping_ratio and rolling_resistance 0): the one whose
    orbits and tubes a dissipative run's orbits and tubes scenes compute."""
    off = {k: 0.0 for k in ("damping_ratio", "rolling_resistance", "noise", "temperature") if k in model.parameters}
    return model.replace(**off) if off else model


_REGION_NOUT, _REGION_CURVE = 4096, 4096


def _region(model, st, de, area_tol, n_init=0, n_scan=0, xtol=0.0, noiseless=False):
    """The core's transition region at de (tubes_study region_at) with the settings st (noiseless: the
    region of the model without its noise, the Monte Carlo's D -> 0 limit)."""
    (stat, n, phi, rho, s, p, t_in, m, cs, cp, res, counts) = _lib().transition_region(
        *_study(model, st), *_section_args(st), float(de), float(st["mc_gate"]), float(st["mc_t_max"]),
        float(area_tol), int(n_init), int(n_scan), float(xtol), *_integ(st, model), _REGION_NOUT, _REGION_CURVE,
        int(bool(noiseless)), model._stores())
    empty = bool(counts[6])
    out = {"dE": float(de), "status": int(stat), "empty": empty, "area": 0.0 if empty else float(res[0]),
           "area_polygon": float(res[1]), "A_E": float(res[7]), "centre": res[2:4].copy(), "scale": res[4:6].copy(),
           "damping_rate": float(res[6]), "dE_threshold": (float(res[8]), float(res[9])),
           "area_at_threshold": float(res[10]), "area_change": float(res[11]),
           "phi": phi[:n].copy(), "rho": rho[:n].copy(), "r": s[:n].copy(), "p_r": p[:n].copy(),
           "t_in": t_in[:n].copy(), "curve_r": cs[:m].copy(), "curve_p_r": cp[:m].copy(),
           "n_scan": int(counts[0]), "n_scan_transit": int(counts[1]), "n_scan_undecided": int(counts[2]),
           "n_inconsistent": int(counts[3]), "n_integrated": int(counts[4]), "rounds": int(counts[5])}
    out["p_trans"] = out["area"] / out["A_E"] if out["A_E"] > 0 else float("nan")
    return out


def transition_region(model: Model | None = None, dE: float | None = None, saddle=None, saddle_near=None,
                      section=None, area_tol=None, t_max=None, gate=None, integrator: dict | None = None,
                      equilibria: dict | None = None, n_init: int = 0, n_scan: int = 0, xtol: float = 0.0) -> dict:
    """The transition region at dE (docs/dissipation.md; 2 degrees of freedom): the points of the
    section's energy surface at E_e + dE whose trajectory under the model, with its dissipation
    (damping_ratio), passes the saddle's gate before it meets the section again. Its boundary is
    the cut of the section with the stable manifold of the (damped) saddle equilibrium; for a
    conservative model it is the tube's cut (tube_cut), found here by a second method: shooting
    along rays from a point inside, each boundary point bisected between a transit and a return.

    dE: the excess energy above the saddle (> 0, the model's energy units), required. gate and
    t_max: the transit test's (&montecarlo's, their defaults); area_tol: the area's relative
    accuracy (&transition's default); n_init (rays of the first round), n_scan (the scan grid's
    points per axis), xtol (the bisection's relative accuracy): 0 for the program's defaults
    (src/transport/tubes_region.f90). saddle, saddle_near, section, integrator, equilibria as in
    tube_cut.

    Returns a dict: dE, area, p_trans (area / A_E), A_E, empty (no point transits; then
    dE_threshold = (lo, hi): none at or below lo, a region of area_at_threshold at hi), the
    rays phi, rho (scaled coordinates about centre, scale), r, p_r (the boundary points), t_in
    (flight time of the last transit of each ray's bisection), curve_r, curve_p_r (the boundary
    interpolated at 4096 angles), area_polygon, damping_rate, n_scan, n_scan_transit,
    n_scan_undecided, n_inconsistent (scan points on the wrong side: 0), n_integrated, rounds,
    status. Raises TubesError where the program's scenes fail (err.partial holds the dict)."""
    model = model or Model()
    _need_2dof(model, "transition_region", "transition")
    if dE is None:
        raise ValueError("transition_region: give dE, the excess energy above the saddle (> 0, in the model's "
                         "energy units)")
    mc = {k: v for k, v in (("t_max", t_max), ("gate", gate)) if v is not None}
    tra = {"de": [_scalar_de(dE, "transition_region")]}
    if area_tol is not None:
        tra["area_tol"] = _args.real("transition_region", "area_tol", area_tol)   # its range: the reader's
    n_init = _args.integer("transition_region", "n_init", n_init, lo=0)
    n_scan = _args.integer("transition_region", "n_scan", n_scan, lo=0)
    xtol = _args.real("transition_region", "xtol", xtol, lo=0)
    st = _settings(model, saddle, saddle_near, section=section, who="transition_region", montecarlo=mc,
                   transition=tra, integrator=integrator, equilibria=equilibria)
    out = _table(_region(model, st, float(st["des"][0, 2]), st["tra_area_tol"], n_init, n_scan, xtol), "/tubes/region_0",
                 model)
    if out["status"] < 0:
        err = TubesError(out["status"], f"transition_region(dE = {out['dE']:g})")
        err.partial = out
        raise err
    return out


def transition(model: Model | None = None, dE=None, saddle=None, saddle_near=None,
               section=None, area_tol=None, integrator: dict | None = None, equilibria: dict | None = None,
               check: bool = True, **orbits) -> dict:
    """p_trans(dE) = A_tube / A_E (as the transition scene; 2 degrees of freedom).

    dE: excess energies above the saddle, > 0 and increasing, in the model's energy units
    ((cm/s)^2 for the ball); default &transition de (the paper's 14 energies 1 .. 750 (cm/s)^2):
    the rolling ball only, required for any other model. area_tol: &transition's (default the
    reader's); saddle, saddle_near, section, integrator, equilibria and &orbits' keywords as in
    tube_cut.

    Every energy is computed, as the scene does: where a cut or the energy surface failed (past
    the end of the orbit family, a cut that did not converge) A_tube, action and p_trans are NaN;
    where the energy surface on the section failed A_E and p_trans are NaN (as in the output
    file's /transition, docs/output.md), status holds the TUBES_* code (0 where it
    worked; tubes.EPASTEND past the family's end) and message the program's messages on it.
    The numbers, statuses and messages are the program's transition scene's
    (src/workflow/tubes_scene_transition.f90, its result record), bit for bit; where the energy
    surface at the saddle's energy fails (the scene's /section) it raises TubesError with the
    program's message, as ./tubes exits 2 there. A dissipative model's Table adds A_region,
    p_trans_conservative, status_conservative, region_rays, its dissipation, damping_rate and
    dE_threshold (lo, hi), as /transition (status: the region's).

    check (default True): where an energy failed, raise TubesError (its code the first failed
    energy's status, its ``partial`` the whole Table) as ./tubes exits 4 there; check=False returns
    the Table with a RuntimeWarning naming the failed energies. Returns a tubes.Table of arrays dE,
    A_tube, action, A_E, p_trans, p_trans_leading, status, and message (list of str, '' where it
    worked)."""
    model = model or Model()
    _need_2dof(model, "transition", "transition")
    de = _de_list(dE, "transition")
    if de is None:
        _default_de(model, "transition", "transition")
    tra = {} if area_tol is None else {"area_tol": float(area_tol)}
    if de is not None:
        tra["de"] = de
    st = _settings(model, saddle, saddle_near, section=section, who="transition", orbits=orbits, transition=tra,
                   integrator=integrator, equilibria=equilibria)
    de = np.array(st["des"][:int(st["ndes"][2]), 2])
    check = _args.flag("transition", "check", check)
    diss = _dissipation(model)
    # the program's transition scene (src/workflow/tubes_scene_transition.f90): its record's
    # /transition, its messages per energy, its verdicts
    _section_args(st)
    units = str(model.info.get("length_units", "1")) == "cm"
    rec = _scene("transition", st, model, flags=(units,),
                 text1=", ".join(f"{k} = {v:g}" for k, v in diss.items() if k != "dissipation"))
    errs = [t for s, t in rec["lines"] if s == 2]
    if "transition" not in rec["data"]:       # the section failed: the scene stopped there
        codes = [int(c) for c in re.findall(r"\(status (-?\d+)\)", " ".join(errs))]
        raise TubesError(codes[0] if codes else -1, "transition: " + "; ".join(errs))
    g = rec["data"]["transition"]
    out = {k: g[k] for k in ("dE", "A_tube", "action", "A_E", "p_trans", "p_trans_leading", "status")}
    out["message"] = _energy_messages(de, errs)
    if diss:
        a = rec["attrs"]["transition"]
        stat, rate, _ = _lib().dissipation_rates(model.name, model.params())
        out.update(A_region=g["A_region"], p_trans_conservative=g["p_trans_conservative"],
                   status_conservative=g["status_conservative"], region_rays=g["region_rays"],
                   **_recorded_dissipation(a),
                   damping_rate=float(rate) if stat >= 0 else np.nan,
                   dE_threshold=(a["dE_threshold_lo"], a["dE_threshold_hi"]))
    return _failed_energies(_table(out, "/transition", model), check, rec["code"] != 0)


def _energy_messages(de, errs):
    """The scene's stderr lines per energy (each names its energy "dE = %g"), '; '-joined; '' where
    the energy worked."""
    msg = [[] for _ in de]
    at = {f"{d:g}": i for i, d in enumerate(de)}
    for t in errs:
        m = re.search(r"dE = ([-+0-9.e]+)[ :]", t)
        if m and m.group(1) in at:
            msg[at[m.group(1)]].append(t)
    return ["; ".join(m) for m in msg]


def _failed_energies(t, check, failed):
    """transition()'s end: where the scene failed at an energy (failed: the program exits non-zero;
    the energies with a message), the TubesError of ./tubes' exit 4 (check) or a RuntimeWarning
    (check=False); the Table is the error's partial."""
    bad = np.flatnonzero([bool(m) for m in t["message"]]) if failed else np.zeros(0, dtype=int)
    if bad.size == 0:
        return t
    at = "transition: failed at dE = " + ", ".join(f"{d:g}" for d in t["dE"][bad])
    if check:
        k = bad[0]
        code = int(t["status"][k]) or int(t.get("status_conservative", t["status"])[k]) or -1
        err = TubesError(code, at + " (NaN there; the Table, its status and message per "
                         f"energy, in partial; check=False returns it); at dE = {t['dE'][k]:g}: {t['message'][k]}")
        err.partial = t
        raise err
    import warnings
    warnings.warn(at + " (NaN there; status and message hold why): " + "; ".join(m for m in t["message"] if m),
                  RuntimeWarning, stacklevel=3)
    return t


def _mc_agreement(n: int, n_transit: int, n_undecided: int, misclassified: int, p: float) -> dict:
    """The Monte Carlo check's verdict on n points against the tube's p, as the montecarlo scene
    decides it (src/transport/tubes_transport.f90 mc_agreement, the rule's one definition): the
    distance in standard errors of a binomial count with p, the limits of misclassified and
    undecided points, and whether the check agrees."""
    sig, lim, mis_lim, und_lim, agrees = _lib().mc_agreement(n, n_transit, n_undecided, misclassified, p)
    return {"sigmas": float(sig), "sigma_limit": float(lim), "misclassified_limit": int(mis_lim),
            "undecided_limit": int(und_lim), "agrees": bool(agrees)}


class DisagreementError(RuntimeError):
    """The Monte Carlo check failed as the montecarlo scene's does (its exit 2): the count and the
    tube disagree, or too many points are misclassified or undecided. ``partial`` holds the
    result dict (with ``agrees`` False)."""

    def __init__(self, message: str, partial: dict):
        self.partial = partial
        super().__init__(message)


def monte_carlo(model: Model | None = None, dE: float | None = None, n_samples: int | None = None,
                seed: int | None = None, saddle=None, saddle_near=None, section=None, t_max=None,
                gate=None, area_tol=None, integrator: dict | None = None, equilibria: dict | None = None,
                check: bool = True, **orbits) -> dict:
    """The Monte Carlo check at dE (as the montecarlo scene; 2 degrees of freedom): n_samples
    points uniform on the section's energy surface, each integrated until it passes the saddle's
    gate (transit) or returns, counted against the tube's p_trans = A_tube / A_E.

    dE: the excess energy above the saddle, in the model's energy units ((cm/s)^2 for the ball);
    > 0. Default &montecarlo de (100 (cm/s)^2, the paper's): the rolling ball only, required for
    any other model. n_samples (1 .. 10^7, default 10000), seed (>= 0, GSL's MT19937, default
    12345), t_max [time units] (default the system's), gate [units of q] (default the system's),
    area_tol: &montecarlo's, defaults and ranges from the program's reader (docs/input.md).
    saddle or saddle_near, section, integrator, equilibria and &orbits' keywords as in tube_cut.

    check (default True): raise DisagreementError (the result in err.partial) when the check
    fails as the program's does (it exits 2): the fraction more than MC_SIGMA = 5 standard
    errors sqrt(p(1-p)/n) from p_trans, more than 2 + n/1000 misclassified or more than
    2 + n/100 undecided points (t_max too short, or a section or gate that does not fit the
    saddle). check=False returns the dict with agrees False instead.

    Returns a tubes.Table (a dict; its keys also attributes): dE, n_samples, seed, status (0; the
    file's /montecarlo@status), fraction, std_error (sqrt(f(1-f)/n)), p_trans,
    misclassified, misclassified_inside_no_transit, misclassified_outside_transit, undecided,
    escaped (left for good through another exit: no transition), agrees, sigmas (|fraction -
    p_trans| in standard errors), sigma_limit (MC_SIGMA), misclassified_limit, undecided_limit,
    and per point r, p_r, transit (0 returned, 1 transited, 2 undecided, 3 escaped), inside (the
    cut)."""
    model = model or Model()
    _need_2dof(model, "monte_carlo", "montecarlo")
    check = _args.flag("monte_carlo", "check", check)
    mc = {k: v for k, v in (("de", _scalar_de(dE, "monte_carlo")), ("n_samples", n_samples), ("seed", seed),
                            ("t_max", t_max), ("gate", gate), ("area_tol", area_tol)) if v is not None}
    if dE is None:
        _default_de(model, "monte_carlo", "montecarlo")
    st = _settings(model, saddle, saddle_near, section=section, who="monte_carlo", orbits=orbits, montecarlo=mc,
                   integrator=integrator, equilibria=equilibria)
    de, ns, seed = float(st["mc_de"]), int(st["mc_n_samples"]), int(st["mc_seed"])
    diss = _dissipation(model)
    noisy = "noise" in diss.get("dissipation", "")
    # the program's montecarlo scene (src/workflow/tubes_scene_montecarlo.f90): its record's
    # /montecarlo, its messages, its verdict
    _section_args(st)
    rec = _scene("montecarlo", st, model, flags=(str(model.info.get("length_units", "1")) == "cm", noisy),
                 text1=", ".join(f"{k} = {v:g}" for k, v in diss.items() if k != "dissipation"),
                 text2="monte_carlo: ")
    errs = [t for s, t in rec["lines"] if s == 2]
    a = rec["attrs"].get("montecarlo")
    if a is None:       # the section failed: the scene stopped there
        codes = [int(c) for c in re.findall(r"\(status (-?\d+)\)", " ".join(errs))]
        raise TubesError(codes[0] if codes else -1, "monte_carlo: " + "; ".join(errs))
    g = rec["data"].get("montecarlo", {})
    if a["status"] < 0:     # as the scene: why, how many samples failed, and the first
        err = TubesError(a["status"], "monte_carlo: " + "; ".join(errs))
        err.partial = Table({"dE": de, "n_samples": ns, "seed": seed, "status": int(a["status"]),
                             **{k: g[k].copy() for k in ("r", "p_r", "transit") if k in g}, "agrees": False})
        raise err
    ins = g["inside"] == 1
    damped = {}
    if diss:
        stat, rate, _ = _lib().dissipation_rates(model.name, model.params())
        damped = {**_recorded_dissipation(a), "damping_rate": float(rate) if stat >= 0 else np.nan,
                  "p_trans_conservative": a["p_trans_conservative"], "predicted_by": a["predicted_by"]}
    nt, nu = int(np.sum(g["transit"] == 1)), a["undecided"]
    out = Table({"dE": de, "n_samples": ns, "seed": seed, "status": 0, "fraction": a["fraction"],
                 "std_error": a["std_error"], "p_trans": a["p_trans"], **damped, "misclassified": a["misclassified"],
                 "misclassified_inside_no_transit": a["misclassified_inside_no_transit"],
                 "misclassified_outside_transit": a["misclassified_outside_transit"], "undecided": nu,
                 "escaped": a["escaped"], **({"trapped": a["trapped"]} if diss else {}),
                 **_mc_agreement(ns, nt, nu, a["misclassified"], a["p_trans"]),
                 "r": g["r"], "p_r": g["p_r"], "transit": g["transit"], "inside": ins})
    out = _table(out, "/montecarlo", model)
    out["agrees"] = bool(a["agrees"])
    out["verdicts"] = errs if rec["code"] else []
    if check and rec["code"]:
        raise DisagreementError("; ".join(errs) + " (check=False returns the result with agrees False)", out)
    return out


def poincare(model: Model | None = None, dE: float | None = None, n_seeds=None, n_iter=None, t_max=None,
             saddle=None, saddle_near=None, section=None, integrator: dict | None = None, equilibria: dict | None = None) -> Table:
    """Poincare map of the section at dE (as the sections scene, a group /sections/map_K of the
    output file): a tubes.Table with points, an array (n_seeds, n_iter, 2) of (s, p_s) (the ray's
    (r, p_r)) of each return of each trajectory, NaN after one stops returning within t_max, and
    dE, status, n_seeds, n_iter, t_max. Raises TubesError if a trajectory failed (its code the
    map's status, its message the scene's; the Table is in err.partial). 2 degrees of freedom.

    dE: the excess energy above the saddle, > 0, in the model's energy units ((cm/s)^2 for the
    ball); required (the scene's default list, &sections de = 100, 500, is the ball's and a list).
    n_seeds (1 .. 100000, default 40), n_iter (returns per seed), t_max [time units] per return:
    &sections', defaults and ranges from the program's reader (docs/input.md); saddle,
    saddle_near, section, integrator, equilibria as in tube_cut."""
    model = model or Model()
    _need_2dof(model, "poincare", "sections")
    if dE is None:
        raise ValueError("poincare: give dE, the excess energy above the saddle (> 0, in the model's energy units)")
    pm = {k: v for k, v in (("de", [_scalar_de(dE, "poincare")]), ("n_seeds", n_seeds), ("n_iter", n_iter),
                            ("t_max", t_max)) if v is not None}
    st = _settings(model, saddle, saddle_near, section=section, who="poincare", sections=pm, integrator=integrator,
                   equilibria=equilibria)
    # the program's sections scene, its map at dE (src/workflow/tubes_scene_sections.f90): its
    # record's /sections/map_000 and its verdict
    de = float(st["des"][0, 3])
    _section_args(st)
    rec = _scene("sections", st, model, flags=(0, bool(_dissipation(model))))
    status = rec["attrs"]["sections/map_000"]["status"]
    out = _table({"dE": de, "points": rec["data"]["sections/map_000"]["points"], "status": status,
                  "n_seeds": int(st["pm_n_seeds"]), "n_iter": int(st["pm_n_iter"]), "t_max": float(st["pm_t_max"])},
                 "/sections/map_0", model)
    if rec["code"]:
        err = TubesError(status, "; ".join(t for s, t in rec["lines"] if s == 2))
        err.partial = out
        raise err
    return out


def synthetic_experiment(model: Model | None = None, n_tracks=None, duration=None, camera_rate=None,
                         pixel=None, noise=None, de_min=None, de_max=None, damping_ratio=None, seed=None,
                         saddle=None, integrator: dict | None = None, equilibria: dict | None = None,
                         rolling_resistance=None) -> dict:
    """Synthetic tracks of the rolling ball, as the synthetic_experiment scene (the same call, the
    same numbers; docs/experiment-data.md): n_tracks balls released from rest at g H - E_e in
    [de_min, de_max], E_e the saddle's energy, integrated with damping ratio damping_ratio and
    rolling resistance rolling_resistance (the model's own are replaced), filmed at camera_rate [Hz] for duration [s] with Gaussian noise [cm]
    rounded to pixel [cm]. Keywords as &experiment (defaults from the program's reader; the &model
    damping ratio is the theory's, &experiment's the tracks'). dict as the scene's /tracks: arrays
    track, t, x, y (measured) per frame; truth (dict: state (n, 4), energy, dE, noisy (n, 2),
    release (n_tracks, 2), release_dE); and E_e, saddle, damping_rate [1/s], n_draws, n_samples
    (frames per track), box, rtol and the settings used."""
    model = model or Model()
    ex = {k: v for k, v in (("n_tracks", n_tracks), ("duration", duration), ("camera_rate", camera_rate),
                             ("pixel", pixel), ("noise", noise), ("de_min", de_min), ("de_max", de_max),
                             ("damping_ratio", damping_ratio), ("rolling_resistance", rolling_resistance),
                             ("seed", seed)) if v is not None}
    # the program's reader refuses a model other than the ball on its four-well surface, with its message
    st = _settings(model, saddle, who="synthetic_experiment", run={"scenes": "synthetic_experiment"}, experiment=ex,
                   integrator=integrator, equilibria=equilibria)
    # the program's synthetic_experiment scene (src/workflow/tubes_scene_synthetic_experiment.f90):
    # its record's /tracks and its verdicts (a request that leaves no tracks: ValueError)
    rec = _scene("synthetic_experiment", st, model)
    errors = "; ".join(t for s, t in rec["lines"] if s == 2 and t.startswith("tubes: "))
    if "tracks" not in rec["data"]:
        raise ValueError(errors)
    a = rec["attrs"]["tracks"]
    if rec["code"]:
        raise TubesError(a["status"], errors)
    g, truth = rec["data"]["tracks"], rec["data"]["tracks/truth"]
    return _table({"track": g["track"], "t": g["t"], "x": g["x"], "y": g["y"], "truth": truth,
                  "E_e": a["E_e"], "saddle": a["saddle"], "damping_rate": a["damping_rate"], "n_draws": a["n_draws"],
                  "n_samples": a["n_samples"], "n_tracks": a["n_tracks"], "box": a["box"], "rtol": a["rtol"],
                  "duration": a["duration"], "camera_rate": a["camera_rate"], "pixel": a["pixel"], "noise": a["noise"],
                  "de_min": a["de_min"], "de_max": a["de_max"], "damping_ratio": a["damping_ratio"],
                  "rolling_resistance": float(st["exp_rolling_resistance"]), "seed": a["seed"]}, "/tracks", model)


SCAN_CONSTANT = 1000   # a formula's constant k is the scan's parameter SCAN_CONSTANT + k (src/workflow/tubes_scan.f90)


def scan(model: Model | None = None, parameter: str | None = None, to=None, n=None, dE=None, saddle=None,
         saddle_near=None, integrator: dict | None = None, equilibria: dict | None = None, p_trans: bool = False,
         section=None, area_tol=None, **orbits) -> Table:
    """Continuation in a model parameter (as the scan scene, docs/scan.md): parameter (a name of
    the model's table, not one of dissipation; or a formula model's constant given as a number,
    each step then the formula's library at that value, built or loaded from the cache) moves
    from its value in the model to `to` in n equal steps (n + 1 values). At each step the equilibria are continued by Newton from the
    previous step's (searched anew after a fold), the saddle's (saddle or saddle_near; the
    system's default) energy, lambda and centre frequencies are taken, and its Lyapunov orbits
    at the excess energies dE (optional; > 0, increasing) are corrected from the previous step's
    orbits. Folds (an equilibrium meeting another and disappearing, or its Jacobian's
    determinant changing sign) are located by bisection to fold_tol |to - start|.

    Returns a Table (docs/output.md, /scan): value (n + 1), n_equilibria, researched, the
    equilibria per step (eq_q (n + 1, 64, N), eq_energy, eq_index, eq_det, eq_name: lists of
    names), saddle_found, saddle_q, saddle_energy, lambda, omega (n + 1, N - 1), and with dE:
    dE, period, action, stability_index, converged, restarted (n + 1, len(dE)); the folds:
    fold_value, fold_bracket, fold_kind ('meet', 'index' or 'box': not a fold, it leaves the search
    box), fold_step (the first row after the fold,
    0-based), fold_q, fold_name,
    fold_partner, n_folds (all found; at most 32 recorded), fold_tol. Keywords: &orbits' method,
    n_segments, tol, rtol, atol, max_iter, n_samples; integrator and equilibria as dicts of their
    groups (as orbit_family's).

    p_trans (default False; needs dE; 2 degrees of freedom, a conservative model, as transition()):
    at each step and each dE, the transition fraction p_trans = A_tube / A_E that transition()
    gives at the step's parameter value (the same calls: the saddle found anew, its family
    continued in energy, the stable tube's cut on the section (section, as transition's; area_tol
    &transition's)); adds p_trans, A_tube, A_E (n + 1, len(dE); NaN where the cut or the energy
    surface failed) and p_trans_status (the TUBES_* code, 0 where it worked, -1 where the step has
    no saddle); a failed step gives a RuntimeWarning naming it. Costs a tube cut per step and dE
    (docs/scan.md)."""
    model = model or Model()
    who = "scan"
    if not isinstance(parameter, str):
        raise TypeError(f"{who}: parameter = {parameter!r} is not a name: give one of the model's parameters")
    ipar, allowed = _lib().scan_parameter_index(model.name, parameter)
    allowed = _str(allowed).strip()
    if ipar < 1:
        extra = (" (a formula's constants given as numbers are scanned, not one defined by a formula of "
                 "others; dissipation parameters are not scanned)" if model.formula else
                 " (dissipation parameters are not scanned: the scan follows the conservative model)")
        raise ValueError(f"{who}: parameter = {parameter!r} is not a parameter the scan takes for system "
                         f"{model.system!r}; allowed: {', '.join(allowed.split()) or 'none'}{extra}")
    if to is None or n is None:
        raise ValueError(f"{who}: give to (the parameter's end value) and n (steps, >= 1)")
    to = _args.real(who, "to", to)
    n = _in_range(who, "scan", "n", n)
    sstat, start = _lib().scan_start_value(model.name, model.params(), ipar)
    _check(sstat, who)
    start = float(start)
    constant = ipar > SCAN_CONSTANT     # a formula's constant: each step's model its own library
    if to == start:
        raise ValueError(f"{who}: to = {to!r} equals the start value {parameter} = {start!r}: allowed any other value")
    # the reader's checks of the end value (alpha > 0, ...); a formula's constant: its library at `to`
    if constant:
        cstat, _, cmsg = _lib().formula_with_constant(model.name, parameter, to)
        if cstat != 0:
            raise ValueError(f"{who}: to = {to!r}: the formula's library with {_str(cmsg).strip()}")
        end = None
    else:
        end = model.replace(**{parameter: to})
    de = _de_list(dE, who)
    p_on = _args.flag(who, "p_trans", p_trans)
    if p_on:
        _need_2dof(model, f"{who}: p_trans=True: p_trans is the transition scene's", "transition")
        if de is None:
            raise ValueError(f"{who}: p_trans=True needs the excess energies: give dE (> 0, increasing)")
    orb = dict(orbits) if de is None else dict(orbits, de=de)
    tra = {} if area_tol is None else {"area_tol": float(area_tol)}
    st = _settings(model, saddle, saddle_near, who=who, orbits=orb, integrator=integrator, equilibria=equilibria,
                   **({"section": section, "transition": tra} if p_on else {}))
    des = np.array(st["des"][:int(st["ndes"][0]), 0]) if de is not None else np.zeros(0)
    if len(des) and int(st["orb_family"]) != 1:
        raise ValueError(f"{who}: family = {orbits.get('family')!r}: the scan follows the orbits of family 1 (the "
                         "saddle's lowest centre frequency; docs/scan.md): allowed family=1, or no dE")
    # the program's scan scene (src/workflow/tubes_scene_scan.f90): its record's /scan and verdicts
    if p_on:
        _section_args(st)
    diss = _dissipation(model)
    rec = _record(_lib().scene_scan(
        st["config"], st["saddle"], _method(int(st["method"]), model), ipar, parameter, to, n, des, int(p_on),
        ", ".join(f"{k} = {v:g}" for k, v in diss.items() if k != "dissipation")))
    errors = [t for s, t in rec["lines"] if s == 2]
    if "scan" not in rec["data"]:      # refused, or failed: the scene's message
        import re  # noqa: PLC0415
        m = re.search(r"\(status (-?\d+)\)", errors[0] if errors else "")
        status = int(m.group(1)) if m else 0
        if rec["code"] == 1 or status == -1:
            raise ValueError("; ".join(errors))
        e = TubesError(status, who)
        e.args = ("; ".join(errors),)
        raise e
    g, f = rec["data"]["scan"], rec["data"].get("scan/folds", {})
    a, fa = rec["attrs"]["scan"], rec["attrs"]["scan/folds"]
    nd = model.ndof
    nfr = len(f.get("value", ()))
    out = {"parameter": parameter, "start": a["start"], "to": to, "n": n, "saddle": st["saddle"],
           "value": g["value"], "n_equilibria": g["n_equilibria"], "researched": g["researched"].astype(bool),
           "eq_q": g["eq_q"][:, :, :nd].copy(), "eq_energy": g["eq_energy"], "eq_index": g["eq_index"],
           "eq_det": g["eq_det"], "eq_name": [s.split() for s in g["eq_names"]],
           "saddle_found": g["saddle_found"].astype(bool), "saddle_q": g["saddle_q"][:, :nd].copy(),
           "saddle_energy": g["saddle_energy"], "lambda": g["lambda"], "omega": g["omega"][:, :max(nd - 1, 0)].copy(),
           "n_folds": fa["n_found"], "fold_value": f["value"], "fold_bracket": f["bracket"],
           "fold_kind": [{1: "meet", 2: "index", 3: "box"}[int(k)] for k in f["kind"]], "fold_step": f["step"],
           "fold_q": f["q"][:, :nd].copy(), "fold_name": f.get("name", []) if nfr else [],
           "fold_partner": f.get("partner", []) if nfr else [], "fold_tol": fa["tol"]}
    if len(des):
        out.update({"dE": g["dE"], "period": g["period"], "action": g["action"],
                    "stability_index": g["stability_index"], "converged": g["converged"].astype(bool),
                    "restarted": g["restarted"].astype(bool)})
    if p_on:
        out.update({k: g[k] for k in ("p_trans", "A_tube", "A_E", "p_trans_status")})
        if errors:      # a step's p_trans failed: NaN there
            import warnings  # noqa: PLC0415
            warnings.warn("; ".join(errors) + " (NaN there)", RuntimeWarning, stacklevel=3)
    del end
    return _table(out, "/scan", model)


def _as_method(f):
    """f(model, ...) as the Model method model.f(...): f's docstring and its signature without
    the model (help(model.transition) shows the keywords, their defaults and the text)."""
    import functools  # noqa: PLC0415
    import inspect  # noqa: PLC0415

    @functools.wraps(f)
    def method(self, *args, **kwargs):
        return f(self, *args, **kwargs)

    sig = inspect.signature(f)
    self_ = inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)
    method.__signature__ = sig.replace(parameters=[self_] + list(sig.parameters.values())[1:])
    method.__doc__ = (f"model.{f.__name__}(...) is tubes.{f.__name__}(model, ...) (there, model=None is the "
                      f"rolling ball, tubes.Model()):\n\n{inspect.cleandoc(f.__doc__)}")
    return method


for _f in (orbit_family, tube_cut, transition, transition_region, monte_carlo, poincare, flux, equilibria,
           section_boundary, normal_form_map, synthetic_experiment, scan):
    setattr(Model, _f.__name__, _as_method(_f))
del _f


def _section(section, level, direction):
    """(kind, level, dir) of a section name: the trajectory scene's rule (tubes_scene_trajectory
    trajectory_section; level: the ray's angle in degrees for 'theta', as &trajectory section_angle)."""
    name = "none" if section is None else str(section)
    # (the raw core: a table look-up, no Ctrl-C handling to set up around it)
    kind, lvl, d, known = _lib()._core.trajectory_section(name, float(level), float(level), int(direction))
    if not known:
        raise ValueError(f"unknown section {section!r}; allowed: none, U1-, U1+, U1, theta, x, y")
    return int(kind), float(lvl), int(d)


_RANGES: dict = {}   # (group, name) -> a registered variable's range (_in_range)


def _in_range(who: str, group: str, name: str, v, label: str | None = None):
    """v checked against the input file's range of &group name, a registered variable (its annotation
    in src/workflow/tubes_config.f90 is the one definition of its range and of the reader's message,
    python/tubes_f2py.f90 registry_range): the float (or int), else ValueError with the reader's
    text. label: the argument's name where it is not the variable's."""
    r = _RANGES.get((group, name))
    if r is None:
        found, lo, hi, lo_open, hi_open, is_int, allowed = _lib().registry_range(group, name)
        if found != 1:
            raise KeyError(f"&{group} {name} is not a registered number")
        r = _RANGES[(group, name)] = (float(lo) if math.isfinite(lo) else None, float(hi) if math.isfinite(hi) else None,
                                      bool(lo_open), bool(hi_open), bool(is_int), _str(allowed).strip())
    lo, hi, lo_open, hi_open, is_int, allowed = r
    label = label or name
    x = _args.integer(who, label, v) if is_int else _args.real(who, label, v)
    if (lo is not None and (x <= lo if lo_open else x < lo)) or (hi is not None and (x >= hi if hi_open else x > hi)):
        raise ValueError(f"{who}: {label} = {v!r} is out of range: allowed {allowed}")
    return x


def _check_integration(who, method, t_end, rtol, atol, h, max_steps, solver, omega_bind, max_iter):
    """The input file's ranges for an integration (docs/input.md, &integrator and &trajectory: the
    reader's own, _in_range), with the same messages; returns (t_end, rtol, atol, h, max_steps,
    omega_bind, max_iter) checked."""
    t_end = _in_range(who, "trajectory", "t_end", t_end)
    rtol = _in_range(who, "integrator", "rtol", rtol)
    atol = _in_range(who, "integrator", "atol", atol)
    h = _in_range(who, "integrator", "h", h)
    max_steps = _in_range(who, "integrator", "max_steps", max_steps)
    zero = isinstance(omega_bind, numbers.Real) and not isinstance(omega_bind, bool) and omega_bind == 0
    if not zero:                                                     # 0: Tao's default (the file's 200)
        omega_bind = _in_range(who, "integrator", "omega_bind", omega_bind)
    omega_bind = float(omega_bind)
    max_iter = _in_range(who, "integrator", "max_iter", max_iter)   # gauss*; 0: its default
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; allowed: {', '.join(METHODS)}")
    if method in FIXED_STEP and not h > 0:
        raise ValueError(f"method {method!r} is fixed-step: give h > 0")
    if solver not in ("newton", "fixed_point"):
        raise ValueError("solver must be 'newton' or 'fixed_point'")
    return t_end, rtol, atol, h, max_steps, omega_bind, max_iter


_ARGS_SEEN: dict = {}   # integrate's arguments already checked (_integrate_args)


def _integrate_args(method, t_end, rtol, atol, h, max_steps, solver, omega_bind, max_iter, level, direction,
                    max_crossings, stop_at_first, section, dt_out):
    """integrate's arguments checked (the input file's ranges, _check_integration, _in_range) and
    resolved (the section, dt_out's default): a tuple. The answer for the same values of the same
    types is kept (a loop over starts calls with the same options: issue 36's per-call cost); an
    argument that is not a plain number, string or None is checked every time."""
    args = (method, t_end, rtol, atol, h, max_steps, solver, omega_bind, max_iter, level, direction,
            max_crossings, stop_at_first, section, dt_out)
    plain = all(a is None or type(a) in (int, float, str, bool) for a in args)
    key = tuple((type(a), a) for a in args) if plain else None
    got = _ARGS_SEEN.get(key) if plain else None
    if got is not None:
        return got
    t_end, rtol, atol, h, max_steps, omega_bind, max_iter = _check_integration(
        "integrate", method, t_end, rtol, atol, h, max_steps, solver, omega_bind, max_iter)
    level = _args.real("integrate", "level", level)
    direction = _args.integer("integrate", "direction", direction, lo=-1, hi=1)
    max_crossings = _args.integer("integrate", "max_crossings", max_crossings, lo=1)
    stop_at_first = _args.flag("integrate", "stop_at_first", stop_at_first)
    if section == "theta":          # the ray's angle [deg], as the input file's section_angle
        level = _in_range("integrate", "trajectory", "section_angle", level, label="level")
    if direction not in (-1, 0, 1):
        raise ValueError(f"direction = {direction} is out of range: allowed -1, 0, 1")
    if dt_out is None:
        dt_out = max(t_end, 1e-300)
    dt_out = _in_range("integrate", "trajectory", "dt_out", dt_out)
    kind, lev, dirn = _section(section, level, direction)
    got = (t_end, rtol, atol, h, max_steps, omega_bind, max_iter, dt_out, kind, lev, dirn, max_crossings,
           stop_at_first)
    if plain:
        if len(_ARGS_SEEN) >= 256:
            _ARGS_SEEN.clear()
        _ARGS_SEEN[key] = got
    return got


def integrate(state0, t_end: float, dt_out: float | None = None, model: Model | None = None,
              method: str = "auto", rtol: float = 1e-12, atol: float = 1e-12, h: float = 0.0,
              max_steps: int = 10_000_000, omega_bind: float = 0.0, solver: str = "newton",
              max_iter: int = 0, section: str | None = None, level: float = 0.0,
              direction: int = 0, stop_at_first: bool = False, max_crossings: int = 10_000) -> dict:
    """Integrate from state0 = (q, p) (2N components: (x, y, px, py) for the ball) at t = 0 to
    t_end [the model's time units: s for the ball] with any method of METHODS (default model:
    the ball).

    Samples every dt_out (default: only the end points). Fixed-step methods need h > 0;
    omega_bind is Tao's binding constant, solver and max_iter configure gauss*.
    section: None, "U1-" (theta = pi/4, p_theta > 0), "U1+", "U1", "theta" (the ray at angle
    `level` [deg], as the input file's section_angle; direction = sign of p_theta or 0), "x" or "y" (the line x = level or y = level,
    direction = sign of dx/dt or dy/dt or 0). Every crossing is recorded (on the integrator's
    dense output), up to max_crossings; stop_at_first ends the run at the first one.

    The polar sections (U1*, theta) are the ball's; "x" and "y" are the planes q1 = level and
    q2 = level of any model.

    Returns a dict: t (n,), state (n, 2N), energy (n,), nfev, nsteps, nrejected, niter, status
    (0, or 2 = tubes.FULL with a RuntimeWarning: max_crossings crossings recorded before t_end), and with
    a section crossings = dict t (m,), state (m, 2N), direction (m,), and for theta sections
    r, p_r, p_theta (polar canonical coordinates). Raises TubesError on failure.
    """
    model = model or Model()
    (t_end, rtol, atol, h, max_steps, omega_bind, max_iter, dt_out, kind, lev, dirn, max_crossings,
     stop_at_first) = _integrate_args(method, t_end, rtol, atol, h, max_steps, solver, omega_bind, max_iter,
                                      level, direction, max_crossings, stop_at_first, section, dt_out)
    nmax = math.floor(t_end / dt_out * (1 + 1e-12)) + 2
    mc = max_crossings if kind else 1   # no section: no crossings to hold
    n2 = 2 * model.ndof
    if kind == 1 and model.system != "rolling_ball":
        raise ValueError("the polar ray sections (U1, theta) are the rolling ball's; use 'x' or 'y'")
    code = _method(METHODS[method], model, float(rtol))
    x0 = _vec(state0, n2, "state0", "integrate")
    opts = (float(rtol), float(atol), float(h), int(max_steps), float(omega_bind), 1 if solver == "newton" else 2,
            int(max_iter))
    handle = _kept_integrator(model, code, opts)
    if handle:
        stat, n, t, st, en, nc, ct, cx, cd, cnt = _lib().integrator_trajectory(
            handle, x0, float(t_end), float(dt_out), kind, lev, dirn, int(bool(stop_at_first)), mc, nmax)
    else:
        stat, n, t, st, en, nc, ct, cx, cd, cnt = _lib().trajectory(
            model.name, model.params(), x0, float(t_end), float(dt_out), code, *opts, kind, lev, dirn,
            int(bool(stop_at_first)), mc, nmax)
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
    out["status"] = int(stat)
    if stat == 2:   # TUBES_FULL: the crossing log full before t_end, said as the program says it
        import warnings  # noqa: PLC0415
        warnings.warn(f"integrate: stopped at t = {out['t'][-1]:g}, before t_end = {t_end:g}: the {mc} crossings "
                      f"max_crossings allows were recorded (raise max_crossings, or stop_at_first=True)",
                      RuntimeWarning, stacklevel=2)
    return out


def ensemble(states, t_end: float, model: Model | None = None, method: str = "auto",
             rtol: float = 1e-12, atol: float = 1e-12, h: float = 0.0, max_steps: int = 10_000_000,
             omega_bind: float = 0.0, solver: str = "newton", max_iter: int = 0, threads: int = 0) -> dict:
    """Integrate many states of one model from t = 0 to t_end: states (m, 2 ndof), one per row
    (or one state (2 ndof,); an array with one state per column, as scipy's sol.y, is refused).

    The Taylor method ('auto', 'taylor') integrates them in SIMD lanes, the processor's width at
    a time in lockstep (8 with AVX-512, 4 with AVX, 2 otherwise; the environment variable
    TUBES_LANES forces 1, 2, 4 or 8), and OpenMP threads share the lanes' chunks (`threads`, 0:
    OMP_NUM_THREADS); any other method integrates one state at a time per thread. A row's result
    does not depend on the width, the threads or the other rows (docs/integrators-taylor.md,
    "Ensembles in lanes"); with the
    Taylor method and DOP853 it is bit for bit integrate()'s final state from that row (the other
    methods' final sample in integrate() is their dense output at t_end, which may differ from
    the step's end state in the last bits). Options as integrate's.

    Returns a dict: state (m, 2 ndof) at t_end, status (m,) (0, or the TUBES_* code where that
    row's integration failed: its state is where it stopped), nsteps (m,). Raises TubesError if
    any row failed (err.partial holds the dict)."""
    model = model or Model()
    t_end, rtol, atol, h, max_steps, omega_bind, max_iter = _check_integration(
        "ensemble", method, t_end, rtol, atol, h, max_steps, solver, omega_bind, max_iter)
    threads = _args.integer("ensemble", "threads", threads, lo=0)
    n2 = 2 * model.ndof
    x0 = np.ascontiguousarray(_as_rows(states, n2, "ensemble", "states", "state"))
    if x0.shape[0] < 1:
        raise ValueError(f"ensemble: states must have shape (m, {n2}), m >= 1: got {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise ValueError("states must be finite")
    stat, xs, st, ns = _lib().ensemble(
        model.name, model.params(), x0.T, float(t_end),
        _method(METHODS[method], model, float(rtol)), float(rtol), float(atol), float(h), int(max_steps),
        float(omega_bind), 1 if solver == "newton" else 2, int(max_iter), int(threads))
    if stat < 0:
        raise TubesError(stat, "ensemble")
    out = {"state": xs.T.copy(), "status": st.copy(), "nsteps": ns.copy()}
    if np.any(st < 0):
        err = TubesError(int(st.min()), f"ensemble: {int(np.sum(st < 0))} of {len(st)} rows failed")
        err.partial = out
        raise err
    return out


class Integrator:
    """One model's integrator kept between calls, as heyoka's taylor_adaptive: the model, the
    method and (for the Taylor method) its compiled kernel are set up once, and each propagate()
    is a new integration from t = 0 returning the end state only. integrate() keeps such an
    integrator per model, method and options itself (for 'taylor', 'dop853' and 'auto'; a noisy
    model's is made anew) and costs ~15 us more a call: its checks, samples and arrays
    (docs/benchmarks.md, "One call of tubes.integrate"). The options are integrate()'s.

        it = tubes.Integrator(tubes.Model(), method="taylor", rtol=1e-10, atol=1e-10)
        x, counters = it.propagate(state0, 10.0)

    propagate's state is the last step's end, bit for bit tubes.ensemble's row for the same
    start (and integrate()'s last sample for 'taylor' and 'dop853'). One thread at a time per
    Integrator; close() (or a with block, or garbage collection) frees it."""

    def __init__(self, model: Model | None = None, method: str = "auto", rtol: float = 1e-12,
                 atol: float = 1e-12, h: float = 0.0, max_steps: int = 10_000_000,
                 omega_bind: float = 0.0, solver: str = "newton", max_iter: int = 0):
        self._handle = 0
        self.model = model or Model()
        _, rtol, atol, h, max_steps, omega_bind, max_iter = _check_integration(
            "Integrator", method, 0.0, rtol, atol, h, max_steps, solver, omega_bind, max_iter)
        self.method = method
        self._n2 = 2 * self.model.ndof
        handle, stat = _lib().integrator_open(
            self.model.name, self.model.params(), _method(METHODS[method], self.model, float(rtol)),
            float(rtol), float(atol), float(h), int(max_steps), float(omega_bind),
            1 if solver == "newton" else 2, int(max_iter))
        _check(stat, "Integrator")
        self._handle = int(handle)
        self._propagate = _lib().integrator_propagate

    def propagate(self, state0, t_end: float):
        """Integrate state0 (2 ndof components) from t = 0 to t_end >= 0. Returns (state,
        counters): the final state and [nfev, nsteps, nrejected, niter] of this call. Raises
        TubesError on failure (err.partial = (state where it stopped, counters))."""
        if not self._handle:
            raise ValueError("this Integrator is closed")
        t_end = _in_range("Integrator.propagate", "trajectory", "t_end", t_end)
        x, counters, stat = self._propagate(self._handle, _vec(state0, self._n2, "state0", "Integrator.propagate"), float(t_end))
        if stat < 0:
            err = TubesError(stat, "Integrator.propagate")
            err.partial = (x, counters)
            raise err
        return x, counters

    def close(self):
        """Free the integrator (further propagate calls raise ValueError)."""
        if self._handle:
            _lib().integrator_close(self._handle)
            self._handle = 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __copy__(self):   # a copy would free the same Fortran object twice
        raise TypeError("a tubes.Integrator cannot be copied; make another one")

    __deepcopy__ = __reduce__ = lambda self, *a: self.__copy__()

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


def trajectory(state0, t_end: float, dt_out: float = 0.01, **kw) -> dict:
    """integrate() sampled every dt_out (default 0.01 s); see integrate for the options."""
    return integrate(state0, t_end, dt_out=dt_out, **kw)


def reference_solution(state0, t_end: float, tol: float = 1e-26, model: Model | None = None) -> np.ndarray:
    """Quad-precision (real128) DOP853 solution at t_end, rounded to double: the reference
    that tests and benchmarks measure errors against (conservative model only; docs/events.md
    gives its accuracy and cost: tol 1e-26 to t = 10 s takes about 2 s)."""
    model = model or Model()
    if model.name != "rolling_ball":
        raise ValueError("reference_solution: the real128 reference exists for rolling_ball only")
    if model.damping_ratio != 0:
        raise ValueError("reference_solution: conservative model only")
    t_end = _args.real("reference_solution", "t_end", t_end, lo=0)
    tol = _args.real("reference_solution", "tol", tol, lo=0, lo_open=True)
    stat, x, _, _ = _lib().reference_solution(model.params()[:10], _vec(state0, 4, "state0", "reference_solution"),
                                              float(t_end), float(tol))
    _check(stat, "reference_solution")
    return np.asarray(x)


EDGES = {"periodic": 0, "odd": 1, "mirror": 2}   # src/experiment/tubes_differentiate.f90 EDGE_*
_DIFF_OPTIONS = {"spectral": {"cutoff": 5.0, "rolloff": 0.5, "edge": "mirror", "end_order": 3,
                              "end_window": None},
                 "savgol": {"order": 3, "window": 15}}


def differentiate(x, dt: float, method: str = "spectral", **options):
    """Velocity and smoothed position of samples x taken every dt [s] (src/experiment/tubes_differentiate.f90,
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
    who = f"differentiate({method!r})"
    dt = _args.real(who, "dt", dt, lo=0, lo_open=True)
    if method == "spectral":
        opt["cutoff"] = 0.0 if opt["cutoff"] is None else _args.real(who, "cutoff", opt["cutoff"], lo=0)
        opt["rolloff"] = _args.real(who, "rolloff", opt["rolloff"], lo=0, hi=2, hi_open=True)
        opt["end_order"] = _args.integer(who, "end_order", opt["end_order"], lo=0)
        opt["end_window"] = 0 if opt["end_window"] is None else _args.integer(who, "end_window", opt["end_window"], lo=1)
    else:
        opt["order"] = _args.integer(who, "order", opt["order"], lo=0)
        opt["window"] = _args.integer(who, "window", opt["window"], lo=1)
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
            cutoff, ew = opt["cutoff"], opt["end_window"]
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
    (datasets as numpy arrays, strings decoded), subgroups as nested Results. ``units`` maps
    each dataset to its units (the dataset's own ``units`` attribute); ``"orbits/period" in
    res``, ``res["orbits/period"]`` and ``res.units["orbits/period"]`` take nested paths;
    ``to_pandas()`` and ``to_xarray()`` turn a group's equal-length 1-D datasets into a table
    (pandas / xarray when installed)."""

    def __init__(self, name: str, attrs: dict, items: dict, units: dict | None = None):
        self._name, self.attrs, self._items = name, attrs, items
        self.units = _Units(units or {}, self)

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
        node: Any = self
        for part in key.strip("/").split("/"):
            if not isinstance(node, Result) or (part not in node._items and part not in node.attrs):
                return False
            node = getattr(node, part)
        return True

    def keys(self):
        return list(self._items) + list(self.attrs)

    def to_pandas(self):
        """The group's 1-D datasets of the common length as a pandas DataFrame (units in
        ``df.attrs["units"]``)."""
        return _to_pandas(_columns(self._items, self._name), self.units)

    def to_xarray(self):
        """The group's 1-D datasets of the common length as an xarray Dataset (units as each
        variable's ``units`` attribute)."""
        return _to_xarray(_columns(self._items, self._name), self.units)

    def __repr__(self) -> str:
        return f"<tubes.Result {self._name}: {', '.join(self.keys())}>"


class _Units(dict):
    """A group's units by dataset name (``res.orbits.units["action"]``); a nested path looks in
    the subgroup (``res.units["orbits/action"]``)."""

    def __init__(self, units: dict, group: "Result"):
        super().__init__(units)
        self._group = group

    def __missing__(self, key: str) -> str:
        head, _, rest = key.strip("/").partition("/")
        sub = self._group._items.get(head) if rest else None
        if isinstance(sub, Result):
            return sub.units[rest]
        raise KeyError(key)

    def get(self, key: str, default: Any = None) -> Any:
        try:
            return self[key]
        except KeyError:
            return default

    def __contains__(self, key: object) -> bool:
        return isinstance(key, str) and self.get(key) is not None


class Table(dict):
    """A scene's result as every Python scene call returns it (equilibria, orbit_family, flux,
    tube_cut, transition, transition_region, monte_carlo, section_boundary, normal_form_map,
    synthetic_experiment): a dict of its columns (numpy arrays, lists of names or messages) and
    scalars, read as ``t["period"]`` or as ``t.period``. ``to_pandas()`` and ``to_xarray()`` make
    one table of its 1-D columns of the common length, where pandas / xarray are installed: a
    row per dE (the index, and the xarray coordinate), or per equilibrium (``name``); the units
    are the model's (docs/output.md lists them for the same datasets of the output file)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.units: dict = dict(getattr(args[0], "units", {})) if args else {}
        """the units of its columns (and scalars) as the output file writes them (docs/python.md)"""

    def __getattr__(self, key: str) -> Any:
        try:
            return self[key]
        except KeyError:
            raise AttributeError(f"this tubes.Table has no column {key!r} (its columns: "
                                 f"{', '.join(map(str, self))})") from None

    def __dir__(self):
        return list(super().__dir__()) + [k for k in self if isinstance(k, str) and k.isidentifier()]

    def to_pandas(self):
        """The 1-D columns of the common length as a pandas DataFrame indexed by dE (or name)."""
        return _to_pandas(_columns(self, type(self).__name__, n=_rows(self)), self.units)

    def to_xarray(self):
        """The 1-D columns of the common length as an xarray Dataset with the coordinate dE (or
        name; ``row`` where there is neither)."""
        return _to_xarray(_columns(self, type(self).__name__, n=_rows(self)), self.units)


@functools.lru_cache(maxsize=None)
def _units_of(group: str, name: str, dimensionless: bool) -> str | None:
    """The units of dataset (or attribute) name of group as the output file writes them, from the
    writer's one table (src/io/tubes_units.c), or None where it has no row."""
    stat, u = _lib().dataset_units(group, name, int(dimensionless))
    return _str(u) if stat == 0 else None


def _table(items: dict, group: str, model: "Model") -> Table:
    """items as the Table of the scene whose output group is group (its units: the file's)."""
    t = Table(items)
    dimensionless = str(model.info.get("length_units", "1")) != "cm"
    t.units = {k: u for k in t if isinstance(k, str)
               for u in [_units_of(group, k, dimensionless)] if u is not None}
    return t


def _rows(t: dict) -> int | None:
    """A table's row count: its dE grid's length, else its equilibria's."""
    for k in ("dE", "name"):
        if k in t and np.ndim(t[k]) == 1:
            return len(t[k])
    return None


def _columns(items: dict, name: str, n: int | None = None) -> dict:
    """The 1-D columns (numpy arrays; lists too) of items of the length n (default the longest)."""
    cols = {k: v for k, v in items.items()
            if (isinstance(v, np.ndarray) and v.ndim == 1) or (isinstance(v, list) and n is not None)}
    if not cols:
        raise ValueError(f"{name} has no 1-D datasets to make a table of")
    n = max(len(v) for v in cols.values()) if n is None else n
    return {k: v for k, v in cols.items() if len(v) == n}


def _index(cols: dict) -> str | None:
    """The column a table's rows are labelled by: dE (a row per excess energy), else name (a row
    per equilibrium), else none."""
    return next((k for k in ("dE", "name") if k in cols), None)


def _to_pandas(cols: dict, units: dict):
    import pandas as pd
    df = pd.DataFrame(cols)
    key = _index(cols)
    if key:
        df = df.set_index(key)
    df.attrs["units"] = {k: units.get(k, "") for k in cols}
    return df


def _to_xarray(cols: dict, units: dict):
    import xarray as xr
    key = _index(cols)
    dim = key or "row"
    data = {k: (dim, np.asarray(v), {"units": units.get(k, "")}) for k, v in cols.items() if k != key}
    coords = {key: (key, np.asarray(cols[key]), {"units": units.get(key, "")})} if key else None
    return xr.Dataset(data, coords=coords)


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
    units: dict = {}
    for k, v in node.items():
        if isinstance(v, h5py.Group):
            items[k] = _read(v, f"{name}/{k}".replace("//", "/"))
        else:
            items[k] = _decode(v[()])
            if "units" in v.attrs:
                units[k] = _decode(v.attrs["units"])
    return Result(name, attrs, items, units)


def load(path: str) -> Result:
    """Read a tubes HDF5 output completely into memory."""
    import h5py
    with h5py.File(path, "r") as f:
        return _read(f, "/")
