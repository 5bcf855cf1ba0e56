"""Figures from tubes' HDF5 output (matplotlib, headless).

    python -m tubes.plots RESULT.h5 [-o DIR]

draws every figure the file has data for and prints the paths written.
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys

import numpy as np

from . import _output, load


def _mpl():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def potential_grid(res, X, Y):
    """V on a grid of (x, y) for the model of a result file, by the core (tubes.potentials)."""
    from . import Model, potentials
    q = np.stack([np.ravel(X), np.ravel(Y)], axis=1)
    return potentials(q, Model.of(res)).reshape(np.shape(X))


def plot_orbit_family(res, path):
    """The Lyapunov orbits in (x, y) over the zero-velocity curves g H = E of each energy."""
    plt = _mpl()
    orb = res.orbits
    g = res.model.attrs["g"]
    fig, ax = plt.subplots(figsize=(7, 6))
    xs = np.linspace(-5, 4, 450)
    ys = np.linspace(-1.5, 12.5, 700)
    X, Y = np.meshgrid(xs, ys)
    V = potential_grid(res, X, Y)
    conv = np.asarray(orb.converged, dtype=bool)
    energies = np.asarray(orb.energy)[conv]
    cmap = plt.get_cmap("viridis")
    colors = [cmap(i / max(1, len(energies) - 1)) for i in range(len(energies))]
    ax.contourf(X, Y, V, levels=30, cmap="Greys", alpha=0.35)
    for k, (e, c) in enumerate(zip(energies, colors)):
        ax.contour(X, Y, V, levels=[e], colors=[c], linewidths=0.8, linestyles="--")
    ks = [k for k in range(len(orb.dE)) if conv[k]]
    for j in reversed(range(len(ks))):          # largest first: the small ones stay visible
        k = ks[j]
        o = getattr(orb, f"orbit_{k:03d}")
        ax.plot(o.state[:, 0], o.state[:, 1], color=colors[j], lw=3.0 - 2.0 * j / max(1, len(ks) - 1),
                label=f"dE = {orb.dE[k]:g}")
    ax.plot([res.saddle.x], [res.saddle.y], "k+", ms=10) if "saddle" in res else None
    ax.set_xlabel("x [cm]")
    ax.set_ylabel("y [cm]")
    ax.set_aspect("equal")
    ax.set_title(f"Lyapunov orbits of {orb.saddle} over their zero-velocity curves (dashed)")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    _output.save_figure(fig, path, dpi=130)
    plt.close(fig)


def plot_orbit_properties(res, path):
    """Period, action and mu_unstable against dE, with the dE -> 0 limits."""
    plt = _mpl()
    orb = res.orbits
    conv = np.asarray(orb.converged, dtype=bool)
    de = np.asarray(orb.dE)[conv]
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.8))
    axs[0].plot(de, np.asarray(orb.period)[conv], "o-")
    axs[1].plot(de, np.asarray(orb.action)[conv], "o-", label="action")
    axs[2].semilogy(de, np.asarray(orb.mu_unstable)[conv], "o-")
    if "saddle" in res:
        t_po = res.saddle.T_po
        axs[0].axhline(t_po, color="gray", ls=":", label="T_po = 2 pi / omega")
        axs[1].plot(de, t_po * de, color="gray", ls=":", label="T_po dE (MacKay)")
        axs[2].semilogy(de, np.exp(res.saddle["lambda"] * np.asarray(orb.period)[conv]), color="gray", ls=":",
                        label="exp(lambda T)")
    if "family_end_dE" in orb.attrs:
        for ax in axs:
            ax.axvline(orb.family_end_dE, color="red", ls="--", lw=0.8, label="end of family")
    for ax, lab in zip(axs, ["period [s]", "action [cm^2/s]", "mu_unstable"]):
        ax.set_xlabel("dE [(cm/s)^2]")
        ax.set_ylabel(lab)
        ax.legend(fontsize=7)
    fig.tight_layout()
    _output.save_figure(fig, path, dpi=130)
    plt.close(fig)


def _ray(res):
    sec = res.section.attrs
    th = sec["angle"]
    return sec, np.cos(th), np.sin(th)


def energy_boundary(res, de, n=600):
    """The energy surface's boundary on the section of a result file at E_e + dE, as a closed
    curve (s, p_s) (r, p_r on the ball's ray), computed by the core (tubes.section_boundary)."""
    from . import Model, section_boundary
    sec = res.section.attrs
    model = Model.of(res)
    if "angle" in sec:
        section = {"kind": "ray", "angle": np.degrees(sec["angle"]), "p_theta_sign": int(sec["p_theta_sign"])}
    else:
        section = {"kind": "plane", "index": int(sec["index"]), "value": float(sec["value"]),
                   "direction": int(sec["direction"])}
    b = section_boundary(model, de, saddle=_dec(sec["saddle"]), section=section, m=n)
    return np.concatenate([b["s"], b["s"][::-1]]), np.concatenate([b["p_max"], b["p_min"][::-1]])


def _dec(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def plot_sections(res, outdir):
    """Poincare maps with the tube cut (when computed at the same dE) and the energy boundary."""
    plt = _mpl()
    paths = []
    for name in sorted(k for k in res.sections.keys() if k.startswith("map_")):
        m = getattr(res.sections, name)
        de = m.attrs["dE"]
        pts = m.points
        fig, ax = plt.subplots(figsize=(6.5, 5.5))
        ax.plot(pts[:, :, 0].ravel(), pts[:, :, 1].ravel(), ",", color="k", alpha=0.6)
        br, bp = energy_boundary(res, de)
        ax.plot(br, bp, color="m", lw=1.2, label="energy surface boundary")
        damped = "dissipation" in m.attrs
        if "tubes" in res:
            for k in res.tubes.keys():
                cut = getattr(res.tubes, k)
                if k.startswith("stable") and abs(cut.attrs["dE"] - de) < 1e-9:
                    ax.fill(cut.r, cut.p_r, color="c", alpha=0.5,
                            label="stable tube (conservative model)" if damped else "stable tube (transition)")
                    ax.plot(np.append(cut.r, cut.r[0]), np.append(cut.p_r, cut.p_r[0]), "b", lw=1)
                if k.startswith("region") and abs(cut.attrs["dE"] - de) < 1e-9 and "curve_r" in cut:
                    ax.fill(cut.curve_r, cut.curve_p_r, color="orange", alpha=0.6,
                            label=f"damped region (transition, {_dissipation_text(cut.attrs)})")
        ax.set_xlabel("r [cm]")
        ax.set_ylabel("p_r [cm/s]")
        ax.set_title(f"Poincare section U1^- at dE = {de:g} (cm/s)^2"
                     + (f": the damped ball ({_dissipation_text(m.attrs)})" if damped else ""))
        ax.legend(fontsize=8, loc="upper right")
        fig.tight_layout()
        p = pathlib.Path(outdir) / f"section_dE{de:g}.png"
        _output.save_figure(fig, p, dpi=130)
        plt.close(fig)
        paths.append(p)
    return paths


def _dissipation_text(attrs) -> str:
    """A dissipative run's laws and coefficients from a group's attributes (docs/output.md)."""
    parts = [f"{k} {attrs[k]:g}" for k in ("damping_ratio", "rolling_resistance") if k in attrs]
    return ", ".join(parts)


def plot_transition(res, path):
    """p_trans(dE) = A_tube / A_E beside the leading-order formula (and the Monte Carlo point); for a
    damped model its A_region / A_E, with the conservative model's beside it (docs/dissipation.md)."""
    plt = _mpl()
    tr = res.transition
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    if "p_trans_conservative" in tr:
        ax.plot(tr.dE, tr.p_trans, "o-", label=f"A_region / A_E (damped, {_dissipation_text(tr.attrs)})")
        ax.plot(tr.dE, tr.p_trans_conservative, "^-", color="gray", label="A_tube / A_E (conservative model)")
        ax.plot(tr.dE, tr.p_trans_leading, "--", label="(T_po/A0) dE (1 - tau dE/A0) (conservative)")
    else:
        ax.plot(tr.dE, tr.p_trans, "o-", label="A_tube / A_E (tubes)")
        ax.plot(tr.dE, tr.p_trans_leading, "--", label="(T_po/A0) dE (1 - tau dE/A0)")
    if "montecarlo" in res:
        mc = res.montecarlo.attrs
        ax.errorbar([mc["dE"]], [mc["fraction"]], yerr=[2 * mc["std_error"]], fmt="s", color="r", capsize=3,
                    label=f"Monte Carlo ({mc['n_samples']} points, 2 s.e.)")
    ax.set_xlabel("dE [(cm/s)^2]")
    ax.set_ylabel("transition fraction")
    ax.legend(fontsize=8)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    _output.save_figure(fig, path, dpi=130)
    plt.close(fig)


def plot_tube_trajectories(res, path):
    """The stable tube of the first cut and two trajectories from the section, one inside the cut
    (transition) and one outside, in (x, y) and in (x, y, v_y) (tubes.integrate)."""
    from . import Model, integrate, velocity
    plt = _mpl()
    model = Model.of(res)
    from . import conservative
    damped = conservative(model) is not model
    if damped:     # the tube is the conservative model's (docs/dissipation.md): its trajectories too
        model = conservative(model)
    name = sorted(k for k in res.tubes.keys() if k.startswith("stable"))[0]
    cut = getattr(res.tubes, name)
    de = cut.attrs["dE"]
    fig = plt.figure(figsize=(12, 5.5))
    ax1 = fig.add_subplot(1, 2, 1)
    ax2 = fig.add_subplot(1, 2, 2, projection="3d")
    idx = np.linspace(0, len(cut.r) - 1, 60).astype(int)
    for i in idx:      # the manifold's trajectories from the cut to the orbit (forward in time)
        tr = integrate(cut.state[i], -cut.time[i], dt_out=0.01, model=model)
        v = np.array([velocity(z, model) for z in tr["state"]])
        ax1.plot(tr["state"][:, 0], tr["state"][:, 1], color="c", lw=0.4)
        ax2.plot(tr["state"][:, 0], tr["state"][:, 1], v[:, 1], color="c", lw=0.4)
    # two trajectories: inside and outside the cut
    rc = np.mean(cut.r)
    pin = np.mean(cut.p_r)
    sec, c, s = _ray(res)
    for (rr, pp, col, lab) in [(rc, pin, "r", "inside: transition"),
                               (rc, np.max(cut.p_r) + 0.3 * (np.max(cut.p_r) - np.min(cut.p_r)), "b",
                                "outside: no transition")]:
        # p_theta > 0 from the energy: solve (5/14) p^T M^-1 p = E - V on the diagonal (H_t = 0)
        x, y = rr * c, rr * s
        from . import energy
        e_target = energy(cut.state[0], model)

        def en(pt):
            return energy([x, y, c * pp - s * pt / rr, s * pp + c * pt / rr], model)
        lo, hi = 0.0, 1.0
        while en(hi) < e_target:
            hi *= 2
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if en(mid) < e_target else (lo, mid)
        z0 = [x, y, c * pp - s * lo / rr, s * pp + c * lo / rr]
        tr = integrate(z0, 3.0, dt_out=0.005, model=model)
        v = np.array([velocity(z, model) for z in tr["state"]])
        ax1.plot(tr["state"][:, 0], tr["state"][:, 1], color=col, lw=1.2, label=lab)
        ax2.plot(tr["state"][:, 0], tr["state"][:, 1], v[:, 1], color=col, lw=1.2)
    X, Y = np.meshgrid(np.linspace(-9, 12, 300), np.linspace(-2, 14, 300))
    ax1.contour(X, Y, potential_grid(res, X, Y), levels=[sec["E_e"] + de], colors="k", linewidths=0.8)
    ax1.plot([0, 14 * c], [0, 14 * s], "k--", lw=0.6, label="U1")
    ax1.set_xlim(-9, 12)
    ax1.set_ylim(-2, 14)
    ax1.set_aspect("equal")
    ax1.set_xlabel("x [cm]")
    ax1.set_ylabel("y [cm]")
    ax1.legend(fontsize=7)
    ax1.set_title(f"stable tube at dE = {de:g} and two trajectories" + (" (conservative model)" if damped else ""))
    ax2.set_xlabel("x")
    ax2.set_ylabel("y")
    ax2.set_zlabel("v_y [cm/s]")
    fig.tight_layout()
    _output.save_figure(fig, path, dpi=120)
    plt.close(fig)


def plot_surface(res, path):
    """The surface H with the energetically permitted regions (white) below and above the
    saddle energy: dE = -100 and +100 (cm/s)^2 (the paper's Fig. 1(b, c))."""
    plt = _mpl()
    g = res.model.attrs["g"]
    e_e = res.saddle.attrs["energy"] if "saddle" in res else res.section.attrs["E_e"]
    X, Y = np.meshgrid(np.linspace(-13, 13, 500), np.linspace(-13, 13, 500))
    V = potential_grid(res, X, Y)
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.8))
    cs = axs[0].contour(X, Y, V / g, levels=25, cmap="viridis", linewidths=0.8)
    axs[0].clabel(cs, fontsize=6)
    if "equilibria" in res:
        eq = res.equilibria
        for x, y, n in zip(eq.x, eq.y, eq.name):
            axs[0].plot(x, y, "k+" if n.startswith("S") else ("kx" if n.startswith("R") else "ko"), ms=6)
            axs[0].annotate(n, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    axs[0].set_title("H(x, y) [cm] and the equilibria")
    for ax, de in zip(axs[1:], (-100.0, 100.0)):
        ax.contourf(X, Y, (V > e_e + de).astype(float), levels=[0.5, 1.5], colors=["0.35"])
        ax.contour(X, Y, V, levels=[e_e + de], colors="k", linewidths=0.8)
        ax.set_title(f"permitted region (white), dE = {de:+g} (cm/s)^2")
    for ax in axs:
        ax.set_aspect("equal")
        ax.set_xlabel("x [cm]")
        ax.set_ylabel("y [cm]")
    fig.tight_layout()
    _output.save_figure(fig, path, dpi=120)
    plt.close(fig)


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


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m tubes.plots", description=__doc__.splitlines()[0])
    ap.add_argument("result", help="a tubes HDF5 output file")
    ap.add_argument("-o", "--outdir", default="figures", help="directory for the PNG files (default figures)")
    args = ap.parse_args(argv)
    try:
        check_outdir(args.outdir)
    except _output.OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return _output.EXIT_IO
    try:
        res = load(args.result)
    except (OSError, KeyError, ValueError) as exc:
        print(f"error: {args.result}: cannot read it as a tubes result file ({exc})", file=sys.stderr)
        return 1
    _output.handle_sigterm()
    try:
        with _output.batch():          # every figure drawn first, then written all or none
            written = _draw_all(res, args.outdir)
    except _output.OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return _output.EXIT_IO
    except KeyboardInterrupt as exc:
        return _output.interrupted(exc, "python -m tubes.plots")
    for p in written:
        print(p)
    if not written:
        print("nothing to plot in", args.result)
    return 0


FIGURE_NAMES = ("surface.png", "orbit_family.png", "orbit_properties.png", "p_trans.png", "tube_trajectories.png",
                "tube_cut_3dof.png", "experiment.png", "experiment.h5")   # and section_dE*.png


def check_outdir(outdir) -> None:
    """Before the work: the files these tools may write into outdir that exist already must be
    regular files (tubes._output.check_target); OutputError otherwise."""
    if not os.path.isdir(outdir):
        return
    for name in sorted(os.listdir(outdir)):
        if name in FIGURE_NAMES or (name.startswith("section_dE") and name.endswith(".png")):
            _output.check_target(os.path.join(outdir, name), "-o")


def _draw_all(res, outdir) -> list:
    """Every figure the result file res has data for, into the directory outdir; the paths."""
    check_outdir(outdir)
    out = _output.out_dir(outdir, "-o")
    written = []
    if ("equilibria" in res or "section" in res) and "g" in res.model.attrs:   # the rolling ball's surface
        plot_surface(res, out / "surface.png")
        written.append(out / "surface.png")
    if "orbits" in res:
        figs = [("orbit_properties.png", plot_orbit_properties)]
        if "g" in res.model.attrs:      # over the rolling ball's zero-velocity curves
            figs.insert(0, ("orbit_family.png", plot_orbit_family))
        for name, fn in figs:
            fn(res, out / name)
            written.append(out / name)
    if "sections" in res and "section" in res:
        written += plot_sections(res, out)
    if "transition" in res:
        plot_transition(res, out / "p_trans.png")
        written.append(out / "p_trans.png")
    if "tubes" in res and "section" in res:
        plot_tube_trajectories(res, out / "tube_trajectories.png")
        written.append(out / "tube_trajectories.png")
    if "flux" in res and "tube_cut" in res["flux"]:
        plot_tube_cut3(res, out / "tube_cut_3dof.png")
        written.append(out / "tube_cut_3dof.png")
    return written


if __name__ == "__main__":
    raise SystemExit(main())
