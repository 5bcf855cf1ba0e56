"""Figures from tubes' results (matplotlib, headless), for every model, section kind and DOF.

    python -m tubes.plots RESULT.h5 [-o DIR]

draws every figure the file has data for and prints the paths written.

The figures are built from plotting functions over matplotlib Axes, which also take the results
of the Python calls (tubes.Model(...).transition(...), .monte_carlo(...), .equilibria(), ...):
each takes the data (a group of tubes.load, an h5py group or file, or the dict / tubes.Table of
the Python call) and ax=None (a new figure's Axes), and returns the Axes it drew on:

    surface(res_or_model), permitted_region(res, dE), orbit_family(res), orbit_period(orbits),
    orbit_action(orbits), orbit_multiplier(orbits), poincare_map(res, dE), p_trans(transition),
    monte_carlo(mc), tube_trajectories(res).

Labels come from the data: each dataset's `units` attribute (a dimensionless model's "1" is
written as no unit), else the model's units (the rolling ball's cm and s; `units=` or `model=`
for a Python result), and the section's own coordinates (a ray's r, p_r; a plane q_k = c's
s = q_j, p_s = p_j named as the model names them, /model@coordinates and @momenta).
docs/output.md, "Plots", lists what is drawn for which file.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys

import numpy as np

from . import _output, _units_of, load

# the rolling ball's units of each kind of quantity: those of a quantity of that kind in the output's
# units table (src/io/tubes_units.c), the one definition the writer and tubes.Table use
BALL_UNITS = {kind: _units_of(group, name, False) for kind, (group, name) in
              {"length": ("/equilibria", "x"), "time": ("/orbits", "period"), "momentum": ("/montecarlo", "p_r"),
               "energy": ("/transition", "dE"), "action": ("/transition", "action")}.items()}
# the kind of quantity of each dataset or attribute name (its units: the model's, BALL_UNITS for the ball)
_KIND = {"dE": "energy", "energy": "energy", "E_e": "energy", "period": "time", "time": "time", "T_po": "time",
         "t": "time", "action": "action", "A_tube": "action", "A_E": "action", "A0": "action", "area": "action",
         "A_region": "action", "r": "length", "x": "length", "y": "length", "p_r": "momentum"}


def _mpl():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _ax(ax, figsize=(6.5, 5.0), projection=None):
    """ax, or the Axes of a new figure."""
    if ax is not None:
        return ax
    plt = _mpl()
    fig = plt.figure(figsize=figsize)
    return fig.add_subplot(1, 1, 1, projection=projection)


def _dec(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _is_h5(d) -> bool:
    return type(d).__module__.startswith("h5py")


def _has(d, key) -> bool:
    """key is a dataset, group or attribute of d (a group of tubes.load, an h5py group, a dict)."""
    if d is None:
        return False
    if isinstance(d, dict):
        return key in d
    if _is_h5(d):
        return key in d or key in d.attrs
    return key in d


def _get(d, key, default=KeyError):
    """The dataset (an array), subgroup or attribute key of d (a group of tubes.load, an h5py group
    or file, or a dict / tubes.Table of a Python call); default when absent (KeyError raised)."""
    if _has(d, key):
        if isinstance(d, dict):
            return d[key]
        if _is_h5(d):
            if key in d:
                v = d[key]
                return v[()] if hasattr(v, "dtype") else v
            return _dec(d.attrs[key])
        return d[key]
    if default is KeyError:
        raise KeyError(key)
    return default


def _attrs(d) -> dict:
    if isinstance(d, dict):
        return d
    return {k: _dec(v) for k, v in dict(d.attrs).items()}


def model_units(data=None, model=None) -> dict:
    """The units of a model's quantities (length, time, momentum, energy, action): the rolling
    ball's BALL_UNITS, or {} for a dimensionless model (every quantity "1": no unit written).
    data: a result (its /model@system), model: a tubes.Model."""
    if model is not None:
        return dict(BALL_UNITS) if str(model.info.get("length_units", "1")) == "cm" else {}
    if data is not None and _has(data, "model"):
        system = str(_attrs(_get(data, "model")).get("system", "rolling_ball"))
        return dict(BALL_UNITS) if system == "rolling_ball" else {}
    return {}


def _unit(d, key, units=None) -> str:
    """The units of dataset key of d: its own `units` attribute, else units (model_units) by
    the quantity's kind; "" for a dimensionless quantity."""
    u = None
    if d is not None:
        if _is_h5(d):
            if key in d and "units" in d[key].attrs:
                u = _dec(d[key].attrs["units"])
        elif isinstance(getattr(d, "units", None), dict):   # a loaded group, a tubes.Table
            u = d.units.get(key)
    if u is None and units:
        u = units.get(_KIND.get(key, key))
    u = "" if u is None else str(u)
    return "" if u in ("1", "-", "state units") else u


def label(name: str, unit: str = "") -> str:
    """An axis label: 'name [unit]', or name alone for a dimensionless quantity."""
    return f"{name} [{unit}]" if unit and unit != "1" else name


def _with(value: float, unit: str = "") -> str:
    return f"{value:g} {unit}" if unit and unit != "1" else f"{value:g}"


def coordinate_names(data=None, model=None) -> tuple:
    """The model's coordinate and momentum names: /model@coordinates and @momenta (a formula
    model), else x, y (px, py) in 2 DOF and q1.. (p1..) otherwise."""
    qn = pn = None
    if model is not None:
        f = model.formula or {}
        qn, pn = f.get("coordinates"), f.get("momenta")
        ndof = model.ndof
    else:
        a = _attrs(_get(data, "model")) if data is not None and _has(data, "model") else {}
        qn, pn = a.get("coordinates"), a.get("momenta")
        qn = qn.split() if isinstance(qn, str) else qn
        pn = pn.split() if isinstance(pn, str) else pn
        ndof = int(a.get("ndof", len(qn) if qn else 2))
    if not qn:
        qn = ["x", "y"] if ndof == 2 else [f"q{k + 1}" for k in range(ndof)]
    qn = [str(q) for q in qn]
    if not pn:
        pn = ["p" + q for q in qn] if not qn[0].startswith("q") else ["p" + q[1:] for q in qn]
    return qn, [str(p) for p in pn]


class SectionInfo:
    """A section's kind, coordinate names (r, p_r on a ray; s, p_s on a plane q_k = c, named as
    the model names q_j, p_j), a text and the dict tubes.section_boundary takes."""

    def __init__(self, attrs: dict | None, names=(["x", "y"], ["px", "py"])):
        a = dict(attrs or {})
        qn, pn = names
        if "angle" in a:           # a ray (the file stores the angle in rad; a Python dict in deg)
            rad = float(a["angle"]) if "p_theta_sign" in a and "A0" in a else np.radians(float(a["angle"]))
            self.kind, self.angle = "ray", rad
            sign = int(a.get("p_theta_sign", 1))
            self.names = ("r", "p_r")
            self.text = ("U1^-" if abs(np.degrees(rad) - 45) < 1e-9 and sign == 1
                         else f"the ray theta = {np.degrees(rad):g} deg, p_theta {'>' if sign > 0 else '<'} 0")
            self.boundary = {"kind": "ray", "angle": float(np.degrees(rad)), "p_theta_sign": sign}
        elif "index" in a:
            k, c, d = int(a["index"]), float(a["value"]), int(a.get("direction", 1))
            j = 2 - k if len(qn) == 2 else None
            self.kind, self.index, self.value, self.direction = "plane", k, c, d
            self.names = (qn[j], pn[j]) if j is not None else ("s", "p_s")
            self.text = f"{qn[k - 1]} = {c:g} (d{qn[k - 1]}/dt {'>' if d > 0 else '<'} 0)"
            self.boundary = {"kind": "plane", "index": k, "value": c, "direction": d}
        else:
            self.kind, self.names, self.text, self.boundary = None, ("s", "p_s"), "the section", None


def section_info(data=None, section=None, model=None) -> SectionInfo:
    """The section of a result file (its /section) or the section dict given to a Python call."""
    names = coordinate_names(data, model)
    if section is None and data is not None and _has(data, "section"):
        section = _attrs(_get(data, "section"))
    return SectionInfo(section, names)


def _model(data=None, model=None):
    """The tubes.Model of a result (its /model), or model itself."""
    from . import Model
    if model is not None:
        return model
    if isinstance(data, Model):
        return data
    return Model.of(data)


def potential_grid(res, X, Y, model=None):
    """V on a grid of (x, y) for the model of a result file (or model), by the core (tubes.potentials)."""
    from . import potentials
    q = np.stack([np.ravel(X), np.ravel(Y)], axis=1)
    return potentials(q, _model(res, model)).reshape(np.shape(X))


def _natural_2dof(model) -> bool:
    """A 2-DOF model with a potential (tubes.potentials answers): the surface can be drawn."""
    from . import TubesError
    if model.ndof != 2:
        return False
    try:
        return bool(np.all(np.isfinite(potential_grid(None, np.zeros(1), np.zeros(1), model))))
    except (TubesError, ValueError):
        return False


def _is_ball(data=None, model=None) -> bool:
    return model_units(data, model) == BALL_UNITS


def _equilibria_of(data, model):
    """(x, y, name, energy) of the equilibria: the file's /equilibria, a tubes.equilibria Table,
    or computed (tubes.equilibria) for a Model."""
    from . import Model, equilibria
    if isinstance(data, dict) and "name" in data:
        eq = data
    elif data is not None and not isinstance(data, Model) and _has(data, "equilibria"):
        eq = _get(data, "equilibria")
    else:
        eq = equilibria(model)
    names = [_dec(n) for n in _get(eq, "name")]
    return (np.asarray(_get(eq, "x"), dtype=float), np.asarray(_get(eq, "y"), dtype=float), names,
            np.asarray(_get(eq, "energy"), dtype=float))


def _extent(xs, ys, pad=0.35, minimum=0.5):
    """A square-ish plotting window around the points (x, y): their span and pad of it around."""
    xs, ys = np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)
    ok = np.isfinite(xs) & np.isfinite(ys)
    xs, ys = xs[ok], ys[ok]
    if xs.size == 0:
        return (-1.0, 1.0), (-1.0, 1.0)
    span = max(np.ptp(xs), np.ptp(ys), minimum)
    return ((xs.min() - pad * span, xs.max() + pad * span), (ys.min() - pad * span, ys.max() + pad * span))


def _surface_window(data, model):
    if _is_ball(data, model):
        return (-13.0, 13.0), (-13.0, 13.0)
    x, y, _, _ = _equilibria_of(data, model)
    return _extent(x, y, minimum=1.0)


def surface(data, ax=None, levels=25, window=None, model=None):
    """The potential's contours (the rolling ball: its height H(x, y)) with the equilibria marked
    (wells o, rank-1 saddles +, rank-2 x), for a 2-DOF natural model. data: a result (its /model
    and /equilibria) or a tubes.Model (the equilibria computed), or a tubes.equilibria Table
    with model=. window: ((x0, x1), (y0, y1)), default around the equilibria."""
    from . import Model
    model = _model(None if isinstance(data, dict) and "name" in data else data, model)
    units = model_units(model=model)
    qn, _ = coordinate_names(model=model) if isinstance(data, (Model, dict)) else coordinate_names(data)
    ax = _ax(ax, (6.0, 5.5))
    xr, yr = window or _surface_window(data, model)
    X, Y = np.meshgrid(np.linspace(*xr, 400), np.linspace(*yr, 400))
    V = potential_grid(None, X, Y, model)
    ex, ey, names, energies = _equilibria_of(data, model)
    if _is_ball(model=model):
        shape, what = V / model.g, "H(x, y)"
        lev = levels
    else:
        shape, what = V, f"V({qn[0]}, {qn[1]})"
        lo = float(np.nanmin(V))
        top = float(np.nanmax(energies)) if energies.size else float(np.nanpercentile(V, 50))
        lev = np.linspace(lo, top + max(top - lo, 1e-12), levels) if top > lo else levels
    cs = ax.contour(X, Y, shape, levels=lev, cmap="viridis", linewidths=0.8)
    ax.clabel(cs, fontsize=6)
    for x, y, n in zip(ex, ey, names):
        ax.plot(x, y, "k+" if n.startswith(("S", "L")) else ("kx" if n.startswith(("R", "D")) else "ko"), ms=6)
        ax.annotate(n, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_title(f"{label(what, units.get('length', ''))} and the equilibria")
    ax.set_aspect("equal")
    ax.set_xlabel(label(qn[0], units.get("length", "")))
    ax.set_ylabel(label(qn[1], units.get("length", "")))
    return ax


def _saddle_energy(res) -> float:
    if _has(res, "saddle"):
        return float(_attrs(_get(res, "saddle"))["energy"])
    return float(_attrs(_get(res, "section"))["E_e"])


def permitted_region(res, dE, ax=None, window=None, model=None, energy=None):
    """The energetically permitted region V <= E_e + dE (white; forbidden grey) of a 2-DOF natural
    model, E_e the saddle's energy of the result res (or energy given)."""
    model = _model(res, model)
    units = model_units(model=model)
    qn, _ = coordinate_names(model=model) if res is None else coordinate_names(res)
    e_e = _saddle_energy(res) if energy is None else float(energy)
    ax = _ax(ax, (6.0, 5.5))
    xr, yr = window or _surface_window(res if res is not None else model, model)
    X, Y = np.meshgrid(np.linspace(*xr, 400), np.linspace(*yr, 400))
    V = potential_grid(None, X, Y, model)
    ax.contourf(X, Y, (V > e_e + dE).astype(float), levels=[0.5, 1.5], colors=["0.35"])
    ax.contour(X, Y, V, levels=[e_e + dE], colors="k", linewidths=0.8)
    ax.set_title(f"permitted region (white), dE = {dE:+g}" + (f" {units['energy']}" if units else ""))
    ax.set_aspect("equal")
    ax.set_xlabel(label(qn[0], units.get("length", "")))
    ax.set_ylabel(label(qn[1], units.get("length", "")))
    return ax


def _figure_de(res) -> float:
    """The excess energy of the permitted-region panels: the ball's 100 (cm/s)^2 (the paper's), else
    the first tube cut's dE, the largest transition dE or a tenth of the barrier."""
    if _is_ball(res):
        return 100.0
    for grp, key in (("tubes", None), ("transition", "dE"), ("orbits", "dE")):
        if _has(res, grp):
            g = _get(res, grp)
            if key is None:
                cuts = [k for k in g.keys() if str(k).startswith("stable")]
                if cuts:
                    return float(_attrs(_get(g, cuts[0]))["dE"])
            else:
                return float(np.nanmax(np.asarray(_get(g, key), dtype=float)))
    x, y, n, e = _equilibria_of(res, _model(res))
    e_e = _saddle_energy(res) if (_has(res, "saddle") or _has(res, "section")) else float(np.max(e))
    return max(0.1 * (e_e - float(np.min(e))), 1e-3)


def _orbit_groups(orb):
    conv = np.asarray(_get(orb, "converged"), dtype=bool)
    return conv, [k for k in range(len(conv)) if conv[k] and _has(orb, f"orbit_{k:03d}")]


def orbit_family(res, ax=None, model=None):
    """The periodic orbits of /orbits in (q1, q2), over their zero-velocity curves V = E (dashed;
    2-DOF natural models), the saddle marked."""
    plt = _mpl()
    orb = _get(res, "orbits")
    units = model_units(res)
    qn, _ = coordinate_names(res)
    ax = _ax(ax, (7, 6))
    conv, ks = _orbit_groups(orb)
    energies = np.asarray(_get(orb, "energy"))[ks]
    cmap = plt.get_cmap("viridis")
    colors = [cmap(i / max(1, len(ks) - 1)) for i in range(len(ks))]
    states = [np.asarray(_get(_get(orb, f"orbit_{k:03d}"), "state")) for k in ks]
    if _is_ball(res):
        xr, yr = (-5.0, 4.0), (-1.5, 12.5)
    else:
        pts = np.concatenate([s[:, :2] for s in states]) if states else np.zeros((0, 2))
        if _has(res, "saddle"):
            sd = _attrs(_get(res, "saddle"))
            pts = np.vstack([pts, [[sd["x"], sd["y"]]]])
        xr, yr = _extent(pts[:, 0], pts[:, 1], pad=0.6, minimum=0.2)
    mdl = _model(res, model)
    if _natural_2dof(mdl) and len(energies):
        X, Y = np.meshgrid(np.linspace(*xr, 450), np.linspace(*yr, 450))
        V = potential_grid(None, X, Y, mdl)
        ax.contourf(X, Y, V, levels=30, cmap="Greys", alpha=0.35)
        for e, c in zip(energies, colors):
            ax.contour(X, Y, V, levels=[e], colors=[c], linewidths=0.8, linestyles="--")
    dE = np.asarray(_get(orb, "dE"))
    for j in reversed(range(len(ks))):          # largest first: the small ones stay visible
        s = states[j]
        ax.plot(s[:, 0], s[:, 1], color=colors[j], lw=3.0 - 2.0 * j / max(1, len(ks) - 1),
                label=f"dE = {dE[ks[j]]:g}")
    if _has(res, "saddle"):
        sd = _attrs(_get(res, "saddle"))
        ax.plot([sd["x"]], [sd["y"]], "k+", ms=10)
    ax.set_xlim(*xr)
    ax.set_ylim(*yr)
    ax.set_xlabel(label(qn[0], _unit(_get(res, "equilibria", None), "x", units)))
    ax.set_ylabel(label(qn[1], _unit(_get(res, "equilibria", None), "y", units)))
    ax.set_aspect("equal")
    ax.set_title(f"Lyapunov orbits of {_attrs(orb).get('saddle', 'the saddle')}"
                 + (" over their zero-velocity curves (dashed)" if _natural_2dof(mdl) else ""))
    if ks:
        ax.legend(fontsize=7, loc="upper right")
    return ax


def _orbit_columns(orb):
    conv = np.asarray(_get(orb, "converged"), dtype=bool)
    return conv, np.asarray(_get(orb, "dE"), dtype=float)[conv]


def _orbit_panel(orb, col, name, ax, units, log=False):
    conv, de = _orbit_columns(orb)
    ax = _ax(ax, (4.5, 3.8))
    y = np.asarray(_get(orb, col), dtype=float)[conv]
    (ax.semilogy if log else ax.plot)(de, y, "o-", label=name)
    if _has(orb, "family_end_dE"):
        ax.axvline(float(_get(orb, "family_end_dE")), color="red", ls="--", lw=0.8, label="end of family")
    ax.set_xlabel(label("dE", _unit(orb, "dE", units)))
    ax.set_ylabel(label(name, _unit(orb, col, units)))
    return ax, conv, de


def orbit_period(orbits, ax=None, saddle=None, units=None):
    """The period of the orbit family against dE (a group /orbits or an orbit_family Table), with
    its dE -> 0 limit T_po = 2 pi / omega of the saddle (a /saddle group or dict) when given."""
    ax, conv, de = _orbit_panel(orbits, "period", "period", ax, units)
    if saddle is not None:
        ax.axhline(float(_get(saddle, "T_po")), color="gray", ls=":", label="T_po = 2 pi / omega")
    ax.legend(fontsize=7)
    return ax


def orbit_action(orbits, ax=None, saddle=None, units=None):
    """The action of the orbit family against dE, with T_po dE (MacKay) when the saddle is given."""
    ax, conv, de = _orbit_panel(orbits, "action", "action", ax, units)
    if saddle is not None:
        ax.plot(de, float(_get(saddle, "T_po")) * de, color="gray", ls=":", label="T_po dE (MacKay)")
    ax.legend(fontsize=7)
    return ax


def orbit_multiplier(orbits, ax=None, saddle=None, units=None):
    """The unstable Floquet multiplier against dE (log scale), with exp(lambda T) when the saddle is given."""
    ax, conv, de = _orbit_panel(orbits, "mu_unstable", "mu_unstable", ax, units, log=True)
    if saddle is not None:
        ax.semilogy(de, np.exp(float(_get(saddle, "lambda")) * np.asarray(_get(orbits, "period"))[conv]),
                    color="gray", ls=":", label="exp(lambda T)")
    ax.legend(fontsize=7)
    return ax


def energy_boundary(res, de, n=600, model=None, section=None):
    """The energy surface's boundary on the section of a result file at E_e + dE, as a closed
    curve (s, p_s) (r, p_r on the ball's ray), computed by the core (tubes.section_boundary)."""
    from . import section_boundary
    sec = _attrs(_get(res, "section")) if res is not None else {}
    info = section_info(res, section, model)
    b = section_boundary(_model(res, model), de, saddle=sec.get("saddle"), section=info.boundary, m=n)
    return np.concatenate([b["s"], b["s"][::-1]]), np.concatenate([b["p_max"], b["p_min"][::-1]])


def _dissipation_text(attrs) -> str:
    """A dissipative run's laws and coefficients from a group's attributes (docs/output.md)."""
    parts = [f"{k} {attrs[k]:g}" for k in ("damping_ratio", "rolling_resistance") if k in attrs]
    return ", ".join(parts)


def _section_labels(ax, info, d, units):
    ax.set_xlabel(label(info.names[0], _unit(d, "r", units)))
    ax.set_ylabel(label(info.names[1], _unit(d, "p_r", units)))


def poincare_map(res, dE=None, ax=None):
    """The Poincare map of /sections at dE (default the first), with the stable tube's cut of the
    same dE (/tubes) and the energy surface's boundary, in the section's coordinates."""
    sections = _get(res, "sections")
    names = sorted(k for k in sections.keys() if str(k).startswith("map_"))
    maps = [_get(sections, k) for k in names]
    if dE is not None:
        maps = [m for m in maps if abs(float(_attrs(m)["dE"]) - dE) < 1e-9] or maps
    m = maps[0]
    units = model_units(res)
    info = section_info(res)
    de = float(_attrs(m)["dE"])
    pts = np.asarray(_get(m, "points"))
    ax = _ax(ax, (6.5, 5.5))
    ax.plot(pts[:, :, 0].ravel(), pts[:, :, 1].ravel(), ",", color="k", alpha=0.6)
    br, bp = energy_boundary(res, de)
    ax.plot(br, bp, color="m", lw=1.2, label="energy surface boundary")
    damped = "dissipation" in _attrs(m)
    cut_d = None
    if _has(res, "tubes"):
        tubes_g = _get(res, "tubes")
        for k in tubes_g.keys():
            cut = _get(tubes_g, k)
            if abs(float(_attrs(cut)["dE"]) - de) > 1e-9:
                continue
            if str(k).startswith("stable"):
                r, p = np.asarray(_get(cut, "r")), np.asarray(_get(cut, "p_r"))
                ax.fill(r, p, color="c", alpha=0.5,
                        label="stable tube (conservative model)" if damped else "stable tube (transition)")
                ax.plot(np.append(r, r[0]), np.append(p, p[0]), "b", lw=1)
                cut_d = cut
            if str(k).startswith("region") and _has(cut, "curve_r"):
                ax.fill(_get(cut, "curve_r"), _get(cut, "curve_p_r"), color="orange", alpha=0.6,
                        label=f"damped region (transition, {_dissipation_text(_attrs(cut))})")
    _section_labels(ax, info, cut_d if cut_d is not None else m, units)
    e_unit = _unit(_get(res, "transition", None), "dE", units) or units.get("energy", "")
    ax.set_title(f"Poincare section {info.text} at dE = {_with(de, e_unit)}"
                 + (f": damped ({_dissipation_text(_attrs(m))})" if damped else ""))
    ax.legend(fontsize=8, loc="upper right")
    return ax


def leading_order_valid(de, p_leading, A0=None, tau=None):
    """Where the leading-order p_trans = (T_po/A0) dE (1 - tau dE/A0) is drawn: in [0, 1] and
    before its maximum dE = A0 / (2 tau) (past it the formula falls, no longer a small-dE
    expansion); without A0, tau the maximum is found from the values (still rising)."""
    de, p = np.asarray(de, dtype=float), np.asarray(p_leading, dtype=float)
    ok = np.isfinite(p) & (p >= 0) & (p <= 1) & (de >= 0)
    if A0 is not None and tau is not None and tau > 0:
        ok &= de <= A0 / (2 * tau)
    else:
        rising = np.ones(de.size, dtype=bool)
        order = np.argsort(de)
        dp = np.diff(p[order])
        fall = np.flatnonzero(dp <= 0)
        if fall.size:
            rising[order[fall[0] + 1:]] = False
        ok &= rising
    return ok


def p_trans(data, ax=None, montecarlo=None, section=None, units=None, model=None):
    """p_trans(dE) = A_tube / A_E (a /transition group, or the Table of tubes.transition), beside the
    leading-order formula (T_po/A0) dE (1 - tau dE/A0) where it is valid (leading_order_valid;
    it never sets the axis limits) and the Monte Carlo point (a /montecarlo group or the dict of
    tubes.monte_carlo). section: the /section group (A0, tau); a file's group is found from data.
    A damped model's A_region / A_E with the conservative model's beside it (docs/dissipation.md)."""
    tr = _get(data, "transition") if _has(data, "transition") else data
    if montecarlo is None and _has(data, "montecarlo"):
        montecarlo = _get(data, "montecarlo")
    if section is None and _has(data, "section"):
        section = _get(data, "section")
    units = units if units is not None else model_units(data if _has(data, "model") else None, model)
    ax = _ax(ax, (6.5, 4.5))
    de = np.asarray(_get(tr, "dE"), dtype=float)
    pt = np.asarray(_get(tr, "p_trans"), dtype=float)
    damped = _has(tr, "p_trans_conservative")
    if damped:
        ax.plot(de, pt, "o-", label=f"A_region / A_E (damped, {_dissipation_text(_attrs(tr))})")
        ax.plot(de, _get(tr, "p_trans_conservative"), "^-", color="gray", label="A_tube / A_E (conservative model)")
    else:
        ax.plot(de, pt, "o-", label="A_tube / A_E (tubes)")
    if montecarlo is not None and _has(montecarlo, "fraction"):
        mc = montecarlo
        ax.errorbar([float(_get(mc, "dE"))], [float(_get(mc, "fraction"))], yerr=[2 * float(_get(mc, "std_error"))],
                    fmt="s", color="r", capsize=3, label=f"Monte Carlo ({int(_get(mc, 'n_samples'))} points, 2 s.e.)")
    sec = _attrs(section) if section is not None else {}
    a0, tau, t_po = sec.get("A0"), sec.get("tau"), sec.get("T_po")
    lead = _get(tr, "p_trans_leading", None)
    if lead is None and None not in (a0, tau, t_po):
        lead = t_po / a0 * de * (1 - tau * de / a0)
    if lead is not None:
        ok = leading_order_valid(de, lead, a0, tau)
        if np.any(ok):
            ax.autoscale(False)          # the formula never sets the limits
            ax.plot(de[ok], np.asarray(lead)[ok], "--", label="(T_po/A0) dE (1 - tau dE/A0)"
                    + (" (conservative)" if damped else ""))
            ax.autoscale(True)
    ax.set_xlabel(label("dE", _unit(tr, "dE", units)))
    ax.set_ylabel("transition fraction")
    ax.legend(fontsize=8)
    ax.grid(True, lw=0.3)
    return ax


def monte_carlo(data, ax=None, cut=None, section=None, units=None, model=None):
    """The Monte Carlo points on the section by outcome (returned black, transited red, undecided or
    escaped grey), with the tube's cut (cyan) when given or in the file. data: a /montecarlo group
    (or a result file holding one) or the dict of tubes.monte_carlo; cut: a /tubes group or a
    tubes.tube_cut dict; section: the section dict of the Python call (default the system's)."""
    res = data if _has(data, "montecarlo") else None
    mc = _get(data, "montecarlo") if res is not None else data
    units = units if units is not None else model_units(res, model)
    if model is not None and section is None:        # the system's default section
        d = model.info["section"]
        if d["kind"] == "plane":
            section = {k: d[k] for k in ("index", "value", "direction")}
        elif d["kind"] == "ray":
            section = {"angle": d["angle"], "p_theta_sign": 1}
    info = section_info(res, section, model)
    ax = _ax(ax, (6.5, 5.5))
    if cut is None and res is not None and _has(res, "tubes"):
        tg = _get(res, "tubes")
        de = float(_get(mc, "dE"))
        for k in tg.keys():
            c = _get(tg, k)
            if str(k).startswith("stable") and abs(float(_attrs(c)["dE"]) - de) < 1e-9:
                cut = c
    if cut is not None:
        r, p = np.asarray(_get(cut, "r")), np.asarray(_get(cut, "p_r"))
        ax.fill(r, p, color="c", alpha=0.4, label="stable tube cut")
    r, p = np.asarray(_get(mc, "r")), np.asarray(_get(mc, "p_r"))
    out = np.asarray(_get(mc, "transit"))
    for code, col, lab in ((0, "k", "returned"), (1, "r", "transited"), (2, "0.6", "undecided"),
                           (3, "0.6", "escaped")):
        m = out == code
        if m.any():
            ax.plot(r[m], p[m], ".", ms=2, color=col, label=f"{lab} ({int(m.sum())})")
    _section_labels(ax, info, mc, units)
    ax.set_title(f"Monte Carlo on {info.text} at dE = {_with(float(_get(mc, 'dE')), units.get('energy', ''))}")
    ax.legend(fontsize=7, loc="upper right", markerscale=4)
    return ax


def _start_on_section(model, info, s, ps, e_target):
    """The state on the section at (s, p_s) with energy e_target crossing the section's way, or None
    where (s, p_s) lies outside the energy surface. Ray: solve for p_theta > 0 (the ball's U1^-);
    plane: H is quadratic in the crossing momentum p_k (docs/tubes.md), its root of the
    section's direction from three evaluations."""
    from . import energy
    if info.kind == "ray":
        c, sn = np.cos(info.angle), np.sin(info.angle)
        x, y = s * c, s * sn

        def en(pt):
            return energy([x, y, c * ps - sn * pt / s, sn * ps + c * pt / s], model)
        if en(0.0) > e_target:
            return None
        lo, hi = 0.0, 1.0
        while en(hi) < e_target:
            hi *= 2
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if en(mid) < e_target else (lo, mid)
        return np.array([x, y, c * ps - sn * lo / s, sn * ps + c * lo / s])
    k, j = info.index - 1, 2 - info.index

    def state(pk):
        z = np.zeros(4)
        z[k], z[j], z[2 + k], z[2 + j] = info.value, s, pk, ps
        return z
    e0, e1, em = (energy(state(v), model) for v in (0.0, 1.0, -1.0))
    a, b = 0.5 * (e1 + em - 2 * e0), 0.5 * (e1 - em)
    if a <= 0:
        return None
    pmin = -b / (2 * a)
    emin = e0 - b * b / (4 * a)
    if emin > e_target:
        return None
    # dq_k/dt = dH/dp_k = 2 a (p_k - pmin): the direction's root
    return state(pmin + info.direction * np.sqrt((e_target - emin) / a))


def tube_trajectories(res, ax=None, ax3d=None, n_manifold=60):
    """The stable tube of the first cut (/tubes) in (q1, q2) (and in (q1, q2, dq2/dt) on ax3d, a 3-D
    Axes, when given), its trajectories integrated from the cut to the orbit (tubes.integrate), and
    two trajectories from the section: one inside the cut (transition) and one outside."""
    from . import TubesError, conservative, energy, integrate, velocity
    model = _model(res)
    damped = conservative(model) != model
    if damped:     # the tube is the conservative model's (docs/dissipation.md): its trajectories too
        model = conservative(model)
    units = model_units(res)
    qn, _ = coordinate_names(res)
    info = section_info(res)
    tg = _get(res, "tubes")
    name = sorted(k for k in tg.keys() if str(k).startswith("stable"))[0]
    cut = _get(tg, name)
    de = float(_attrs(cut)["dE"])
    r, p, st, tm = (np.asarray(_get(cut, k)) for k in ("r", "p_r", "state", "time"))
    ball = _is_ball(res)
    t_po = float(_attrs(_get(res, "section")).get("T_po", 1.0))
    dt = 0.01 if ball else t_po / 100
    ax = _ax(ax, (6.5, 5.5))
    seen = []
    for i in np.linspace(0, len(r) - 1, n_manifold).astype(int):  # the manifold: from the cut to the orbit
        tr = integrate(st[i], -tm[i], dt_out=dt, model=model)
        ax.plot(tr["state"][:, 0], tr["state"][:, 1], color="c", lw=0.4)
        seen.append(tr["state"][:, :2])
        if ax3d is not None:
            v = velocity(tr["state"], model)
            ax3d.plot(tr["state"][:, 0], tr["state"][:, 1], v[:, 1], color="c", lw=0.4)
    e_target = energy(st[0], model)
    rc, pin = np.mean(r), np.mean(p)
    span = np.ptp(p)
    outside = None
    for f in (0.3, 0.2, 0.1, 0.05):
        outside = _start_on_section(model, info, rc, np.max(p) + f * span, e_target)
        if outside is not None:
            break
    t_end = 3.0 if ball else 4 * t_po
    runs = []
    for z0, col, lab in ((_start_on_section(model, info, rc, pin, e_target), "r", "inside: transition"),
                         (outside, "b", "outside: no transition")):
        if z0 is None:
            continue
        try:
            tr = integrate(z0, t_end, dt_out=dt / 2, model=model)
        except TubesError as err:      # an escape to infinity (Henon-Heiles above its saddles): up to it
            tr = err.partial
        runs.append((tr["state"], col, lab))
    if ball:
        xr, yr = (-9.0, 12.0), (-2.0, 14.0)
    else:
        allp = np.concatenate(seen)         # the tube, and the equilibria's window where there is one
        if _has(res, "equilibria"):
            ex, ey, _, _ = _equilibria_of(res, model)
            allp = np.vstack([allp, np.column_stack([ex, ey])])
        xr, yr = _extent(allp[:, 0], allp[:, 1], pad=0.1, minimum=0.2)
    for z, col, lab in runs:         # each up to where it leaves the window (an escape)
        far = np.flatnonzero((z[:, 0] < 2 * xr[0] - xr[1]) | (z[:, 0] > 2 * xr[1] - xr[0])
                             | (z[:, 1] < 2 * yr[0] - yr[1]) | (z[:, 1] > 2 * yr[1] - yr[0]))
        z = z[:far[0] + 1] if far.size else z
        ax.plot(z[:, 0], z[:, 1], color=col, lw=1.2, label=lab)
        if ax3d is not None:
            v = velocity(z, model)
            ax3d.plot(z[:, 0], z[:, 1], v[:, 1], color=col, lw=1.2)
    if _natural_2dof(model):
        X, Y = np.meshgrid(np.linspace(*xr, 300), np.linspace(*yr, 300))
        ax.contour(X, Y, potential_grid(None, X, Y, model), levels=[_attrs(_get(res, "section"))["E_e"] + de],
                   colors="k", linewidths=0.8)
    if info.kind == "ray":
        ax.plot([0, 14 * np.cos(info.angle)], [0, 14 * np.sin(info.angle)], "k--", lw=0.6, label="U1")
    elif info.kind == "plane":
        (ax.axvline if info.index == 1 else ax.axhline)(info.value, color="k", ls="--", lw=0.6, label=info.text)
    ax.set_xlim(*xr)
    ax.set_ylim(*yr)
    ax.set_aspect("equal")
    lu = _unit(cut, "r", units) if info.kind == "plane" else units.get("length", "")
    ax.set_xlabel(label(qn[0], lu))
    ax.set_ylabel(label(qn[1], lu))
    ax.legend(fontsize=7)
    ax.set_title(f"stable tube at dE = {de:g} and two trajectories" + (" (conservative model)" if damped else ""))
    if ax3d is not None:
        ax3d.set_xlabel(label(qn[0], lu))
        ax3d.set_ylabel(label(qn[1], lu))
        ax3d.set_zlabel(label(f"v_{qn[1]}", units.get("momentum", "")))
    return ax


def _save(fig, path, dpi):
    plt = _mpl()
    try:
        fig.tight_layout()
        _output.save_figure(fig, path, dpi=dpi)
    finally:
        plt.close(fig)


def plot_surface(res, path):
    """surface.png: the potential with the equilibria, and the permitted regions below and above
    the saddle energy (the ball: dE = -100 and +100 (cm/s)^2, the paper's Fig. 1(b, c); another
    model: -+ the first tube cut's dE, else the largest transition or orbit dE)."""
    plt = _mpl()
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.8))
    model = _model(res)
    window = _surface_window(res, model)
    surface(res, ax=axs[0], window=window, model=model)
    if _has(res, "saddle") or _has(res, "section"):
        de = _figure_de(res)
        for ax, d in zip(axs[1:], (-de, de)):
            permitted_region(res, d, ax=ax, window=window, model=model)
    else:
        for ax in axs[1:]:
            ax.set_visible(False)
    _save(fig, path, 120)


def plot_orbit_family(res, path):
    """orbit_family.png: the Lyapunov orbits over their zero-velocity curves (orbit_family)."""
    ax = orbit_family(res)
    _save(ax.figure, path, 130)


def plot_orbit_properties(res, path):
    """orbit_properties.png: period, action and mu_unstable against dE, with the dE -> 0 limits."""
    plt = _mpl()
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.8))
    orb = _get(res, "orbits")
    saddle = _get(res, "saddle") if _has(res, "saddle") else None
    units = model_units(res)
    for fn, ax in zip((orbit_period, orbit_action, orbit_multiplier), axs):
        fn(orb, ax=ax, saddle=saddle, units=units)
    _save(fig, path, 130)


def plot_sections(res, outdir):
    """section_dE<dE>.png per map of /sections: poincare_map. The paths written."""
    paths = []
    for name in sorted(k for k in _get(res, "sections").keys() if str(k).startswith("map_")):
        de = float(_attrs(_get(_get(res, "sections"), name))["dE"])
        ax = poincare_map(res, de)
        p = pathlib.Path(outdir) / f"section_dE{de:g}.png"
        _save(ax.figure, p, 130)
        paths.append(p)
    return paths


def plot_transition(res, path):
    """p_trans.png: p_trans (with the leading order where valid and the Monte Carlo point)."""
    ax = p_trans(res)
    _save(ax.figure, path, 130)


def plot_tube_trajectories(res, path):
    """tube_trajectories.png: tube_trajectories in (q1, q2) and in (q1, q2, dq2/dt)."""
    plt = _mpl()
    fig = plt.figure(figsize=(12, 5.5))
    ax1 = fig.add_subplot(1, 2, 1)
    ax2 = fig.add_subplot(1, 2, 2, projection="3d")
    tube_trajectories(res, ax=ax1, ax3d=ax2)
    _save(fig, path, 120)


def plot_montecarlo(res, path):
    """montecarlo.png: the Monte Carlo points by outcome with the tube's cut (monte_carlo)."""
    ax = monte_carlo(res)
    _save(ax.figure, path, 130)


def _hull(p):
    """The convex hull of 2-D points p (n, 2), closed (Andrew's monotone chain)."""
    p = np.unique(np.asarray(p, dtype=float), axis=0)

    def half(pts):
        h = []
        for q in pts:
            while len(h) >= 2 and ((h[-1][0] - h[-2][0]) * (q[1] - h[-2][1])
                                   - (h[-1][1] - h[-2][1]) * (q[0] - h[-2][0])) <= 0:
                h.pop()
            h.append(q)
        return h
    lower, upper = half(p), half(p[::-1])
    return np.array(lower[:-1] + upper[:-1] + [lower[0]])


def plot_tube_cut3(res, path, k=-1, slice_width=0.05, max_points=3000):
    """The 3-DOF tube's cut with a 4-D section (the flux scene's /flux/tube_cut, dE index k): its
    projections on the section's two canonical planes (q_a, p_a) and (q_b, p_b), with the Monte Carlo
    points that transit (red) and return (blue); and the paper's inside test: the nodes of the cut
    whose (q_b, p_b) lie within slice_width (relative) of a transiting point's form a circle in
    (q_a, p_a), and the points near that (q_b, p_b) inside it are those that transit."""
    plt = _mpl()
    g = res["flux/tube_cut"]
    de = float(res["flux/dE"][k])
    sec = np.asarray(g.section[k]).reshape(-1, 4)
    ax_names = str(g.attrs["axes"]).split()
    a, b = int(ax_names[0][1:]) - 1, int(ax_names[2][1:]) - 1
    ks = int(g.attrs["section_index"]) - 1
    sec_name = f"q{ks + 1}"
    if "model" in res and "coordinates" in res["model"].attrs and "momenta" in res["model"].attrs:
        qn, pn_ = res["model"].attrs["coordinates"], res["model"].attrs["momenta"]
        qn = qn.split() if isinstance(qn, str) else list(qn)
        pn_ = pn_.split() if isinstance(pn_, str) else list(pn_)
        if len(qn) == 3 and len(pn_) == 3:       # the model's own names
            ax_names = [qn[a], pn_[a], qn[b], pn_[b]]
            sec_name = qn[ks]
    if "points" in g:           # the section's Monte Carlo (natural models)
        pts = np.asarray(g.points[k])
        out = np.asarray(g.outcome[k])
    else:
        pts, out = np.zeros((0, 6)), np.zeros(0, dtype=int)
    nd = pts.shape[1] // 2
    xy = np.stack([pts[:, a], pts[:, nd + a], pts[:, b], pts[:, nd + b]], axis=1)
    rng = np.random.default_rng(0)
    tr = np.flatnonzero(out == 1)
    rt = np.flatnonzero(out == -1)
    rt = rt[rng.permutation(rt.size)[:max_points]]
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.8))
    for j, (i0, lab) in enumerate([(0, ax_names[:2]), (2, ax_names[2:])]):
        ax = axs[j]
        if out.size:
            ax.plot(xy[rt, i0], xy[rt, i0 + 1], ".", ms=1.5, color="tab:blue", alpha=0.4, label="returns")
        hull = _hull(sec[:, i0:i0 + 2])      # the cut's projection: a disk
        ax.fill(hull[:, 0], hull[:, 1], color="tab:green", alpha=0.25, lw=1.5, ec="tab:green",
                label="tube cut (projection)")
        if out.size:
            ax.plot(xy[tr, i0], xy[tr, i0 + 1], ".", ms=3, color="tab:red", label="transits")
        ax.set_xlabel(lab[0])
        ax.set_ylabel(lab[1])
        ax.set_title(f"projection on ({lab[0]}, {lab[1]})")
    axs[0].legend(loc="upper right", fontsize=8, markerscale=3)
    # the slice through a transiting point near the cut's middle
    span = np.ptp(sec[:, 2:4], axis=0)
    ax = axs[2]
    c = np.median(sec[:, 2:4], axis=0)      # through the middle of the cut, or a transiting point near it
    if tr.size:
        c = xy[tr[np.argmin(np.sum(((xy[tr, 2:4] - c) / span) ** 2, axis=1))], 2:4]
    near = np.all(np.abs((sec[:, 2:4] - c) / span) < slice_width, axis=1)
    pn = np.all(np.abs((xy[:, 2:4] - c) / span) < slice_width, axis=1)
    ax.plot(sec[near, 0], sec[near, 1], "o", ms=3, mfc="none", color="0.3", label="cut nodes")
    if out.size:
        ax.plot(xy[pn & (out == -1), 0], xy[pn & (out == -1), 1], ".", color="tab:blue", label="returns")
        ax.plot(xy[pn & (out == 1), 0], xy[pn & (out == 1), 1], ".", color="tab:red", label="transits")
    ax.set_title(f"slice ({ax_names[2]}, {ax_names[3]}) = ({c[0]:.3g}, {c[1]:.3g}) "
                 f"+- {100 * slice_width:.0f} %")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel(ax_names[0])
    ax.set_ylabel(ax_names[1])
    mc = (f"; {int(g.misclassified[k])} of {int(np.sum((out == 1) | (out == -1)))} Monte Carlo points misclassified"
          if out.size else "")
    fig.suptitle(f"stable tube's cut with the section {sec_name} = "
                 f"{float(g.attrs['section_value']):g} (dE = {de:g}): a 3-sphere in 4-D{mc}")
    fig.tight_layout()
    _output.save_figure(fig, path, dpi=110)
    plt.close(fig)


def manifold_cut(cut, ax=None, pairs=(0, 1), label=None, **plot_kw):
    """A tube's cut with a plane in 3 degrees of freedom (a /tubes/<kind>_<k> group of the tubes
    scene, docs/output.md; or a dict with its `section` and `axes`): the closed curve's projection on
    two of the section's coordinates (q_a, p_a, q_b, p_b), columns pairs of `section` (default
    (q_a, p_a)), closed back to its first point. label: the legend entry (default the kind and dE);
    plot_kw go to matplotlib's plot. Returns the axes."""
    sec = np.asarray(_get(cut, "section"))
    at = _attrs(cut)
    names = str(_dec(at.get("axes", "q_a p_a q_b p_b"))).split()
    i, j = pairs
    ax = _ax(ax, (5.5, 4.5))
    if label is None:
        label = f"{_dec(at.get('kind', ''))} (dE = {float(at.get('dE', np.nan)):g})"
    ax.plot(np.append(sec[:, i], sec[0, i]), np.append(sec[:, j], sec[0, j]), label=label, **plot_kw)
    ax.set_xlabel(names[i])
    ax.set_ylabel(names[j])
    return ax


def plot_manifold_cuts(res, path):
    """tube_cut_plane.png: every cut of the tubes scene of a model with 3 degrees of freedom (a
    plane section: /tubes/<kind>_<k>/section), projected on (q_a, p_a), (q_b, p_b) and (q_a, q_b)."""
    plt = _mpl()
    tg = _get(res, "tubes")
    names = sorted(k for k in tg.keys() if str(k).startswith(("stable_", "unstable_")))
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.6))
    first = None
    for n, k in enumerate(names):
        cut = _get(tg, k)
        if not _has(cut, "section"):
            continue
        first = first if first is not None else cut
        for ax, pairs in zip(axs, ((0, 1), (2, 3), (0, 2))):
            manifold_cut(cut, ax=ax, pairs=pairs, color=f"C{n}", lw=1)
    if first is not None:
        at = _attrs(first)
        axs[0].legend(fontsize=8)
        fig.suptitle(f"the tubes' cuts with the plane q{int(at['section_index'])} = {float(at['section_value']):.10g} "
                     f"(family {int(at.get('family', 1))}): closed curves in the section's 4 coordinates")
    _save(fig, path, 110)


def open_result(prog, description, argv):
    """The command line of python -m tubes.plots and tubes.figures: (args, the loaded result, 0), or
    (args, None, exit code) after the message (an output directory refused, exit 3; an unreadable
    result, exit 1). SIGTERM is then handled as Ctrl-C (the writer rule)."""
    ap = argparse.ArgumentParser(prog=prog, description=description)
    ap.add_argument("result", help="a tubes HDF5 output file")
    ap.add_argument("-o", "--outdir", default="figures", help="directory for the PNG files (default figures)")
    args = ap.parse_args(argv)
    try:
        check_outdir(args.outdir)
    except _output.OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return args, None, _output.EXIT_IO
    try:
        res = load(args.result)
    except (OSError, KeyError, ValueError) as exc:
        print(f"error: {args.result}: cannot read it as a tubes result file ({exc})", file=sys.stderr)
        return args, None, 1
    _output.handle_sigterm()
    return args, res, 0


def draw_and_write(prog: str, result, draw, errors: dict | None = None) -> int:
    """A figure command's run (python -m tubes.plots, python -m tubes.figures): draw() makes every
    figure first and returns their paths, all written or none (_output.batch); the paths printed.
    errors: exception class -> its message's prefix, each an exit 1. Returns the exit status."""
    try:
        with _output.batch():
            written = draw()
    except _output.OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return _output.EXIT_IO
    except KeyboardInterrupt as exc:
        return _output.interrupted(exc, prog)
    except tuple(errors or {}) as exc:
        prefix = next(p for k, p in errors.items() if isinstance(exc, k))
        print(f"error: {prefix}{exc}", file=sys.stderr)
        return 1
    for p in written:
        print(p)
    if not written:
        print("nothing to plot in", result)
    return 0


def main(argv=None):
    """The command line, python -m tubes.plots RESULT.h5 [options]: argv without the program's
    name (default sys.argv[1:]); returns the exit status."""
    args, res, rc = open_result("python -m tubes.plots", __doc__.splitlines()[0], argv)
    if res is None:
        return rc
    return draw_and_write("python -m tubes.plots", args.result, lambda: _draw_all(res, args.outdir))


FIGURE_NAMES = ("surface.png", "orbit_family.png", "orbit_properties.png", "p_trans.png", "tube_trajectories.png",
                "montecarlo.png", "tube_cut_3dof.png", "tube_cut_plane.png", "experiment.png",
                "experiment.h5")   # and section_dE*.png


def check_outdir(outdir) -> None:
    """Before the work: the files these tools may write into outdir that exist already must be
    regular files (tubes._output.check_target); OutputError otherwise."""
    if not os.path.isdir(outdir):
        return
    for name in sorted(os.listdir(outdir)):
        if name in FIGURE_NAMES or (name.startswith("section_dE") and name.endswith(".png")):
            _output.check_target(os.path.join(outdir, name), "-o")


def _ndof(res) -> int:
    return int(_attrs(_get(res, "model")).get("ndof", 2)) if _has(res, "model") else 2


def _draw_all(res, outdir) -> list:
    """Every figure the result file res has data for, into the directory outdir; the paths.
    docs/output.md, "Plots", lists them."""
    check_outdir(outdir)
    out = _output.out_dir(outdir, "-o")
    written = []
    two = _ndof(res) == 2
    if two and (_has(res, "equilibria") or _has(res, "section")) and _natural_2dof(_model(res)):
        plot_surface(res, out / "surface.png")
        written.append(out / "surface.png")
    if _has(res, "orbits"):
        for name, fn in (("orbit_family.png", plot_orbit_family), ("orbit_properties.png", plot_orbit_properties)):
            fn(res, out / name)
            written.append(out / name)
    if two and _has(res, "sections") and _has(res, "section"):
        written += plot_sections(res, out)
    if two and _has(res, "transition"):
        plot_transition(res, out / "p_trans.png")
        written.append(out / "p_trans.png")
    if two and _has(res, "montecarlo") and _has(_get(res, "montecarlo"), "transit"):
        plot_montecarlo(res, out / "montecarlo.png")
        written.append(out / "montecarlo.png")
    if two and _has(res, "tubes") and _has(res, "section"):
        plot_tube_trajectories(res, out / "tube_trajectories.png")
        written.append(out / "tube_trajectories.png")
    if not two and _has(res, "tubes"):
        plot_manifold_cuts(res, out / "tube_cut_plane.png")
        written.append(out / "tube_cut_plane.png")
    if _has(res, "flux") and _has(_get(res, "flux"), "tube_cut"):
        plot_tube_cut3(res, out / "tube_cut_3dof.png")
        written.append(out / "tube_cut_3dof.png")
    return written


if __name__ == "__main__":
    raise SystemExit(main())
