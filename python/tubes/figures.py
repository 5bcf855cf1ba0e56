"""Every figure of a tubes result, e.g. the paper's: python -m tubes.figures RESULT.h5 [-o DIR]

Draws the figures of python -m tubes.plots (whatever the file has data for) and, when the file
has /tracks (scene synthetic_experiment), the paper's Fig. 4 from those synthetic tracks: the
analysis of tubes.experiment (the same defaults as python -m tubes.experiment) against the tube
theory of the same file (/section, /transition, /tubes), drawn into DIR/experiment.png and
written to DIR/experiment.h5 (/experiment, docs/experiment.md). Without /tracks that figure is
skipped with a one-line note. docs/paper.md lists every figure.
"""
from __future__ import annotations

import math

import numpy as np

from . import _output, plots

SECTION_RANGE = (40.0, 140.0)   # [(cm/s)^2] the paper's Fig. 4(a): crossings in (40, 140), the cut at 140


def _describe_tracks(attrs: dict) -> str:
    """One line on how the synthetic tracks were made (from the /tracks attributes)."""
    parts = []
    if "n_tracks" in attrs and "duration" in attrs:
        parts.append(f"{int(attrs['n_tracks'])} tracks of {float(attrs['duration']):g} s")
    if "camera_rate" in attrs:
        parts.append(f"{float(attrs['camera_rate']):g} Hz")
    if "damping_ratio" in attrs:
        parts.append(f"zeta = {float(attrs['damping_ratio']):g}")
    if "de_min" in attrs and "de_max" in attrs:
        parts.append(f"released from rest at dE in [{float(attrs['de_min']):g}, {float(attrs['de_max']):g}]")
    if "noise" in attrs and "pixel" in attrs:
        parts.append(f"noise {float(attrs['noise']):g} cm, pixel {float(attrs['pixel']):g} cm")
    return ", ".join(parts)


def plot_experiment(path, an, tracks_attrs: dict, section_range=SECTION_RANGE) -> None:
    """The paper's Fig. 4 from an analysis of synthetic tracks (tubes.experiment.Analysis):
    (a) the U1^- crossings with dE in section_range by outcome, with the stable tube cut at or
    above the range's upper end (cyan) and the energy boundary there (magenta); (b) the
    transition fractions with their intervals and dE errors, the slope fit, A_tube/A_E and
    (T_po/A0) dE. Every label says these are synthetic tracks."""
    from . import experiment as ex
    plt = plots._mpl()
    cm, b, a, th = an.crossings, an.bins, an.attrs, an.theory
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13.0, 5.6))
    lo, hi = section_range
    sel = (cm["dE"] >= lo) & (cm["dE"] < hi)
    cut = th.cut_for(hi) if th is not None else None
    if cut is not None:
        ax1.fill(cut[1], cut[2], color="c", alpha=0.45, label=f"stable tube cut, dE = {cut[0]:g} (tubes)")
        ax1.plot(np.append(cut[1], cut[1][0]), np.append(cut[2], cut[2][0]), "b", lw=1)
    if th is not None and th.result is not None and "section" in th.result and "model" in th.result:
        br, bp = plots.energy_boundary(th.result, hi)
        ax1.plot(br, bp, color="m", lw=1.2, label=f"energy boundary, dE = {hi:g}")
    for code, col, lab in ((ex.OUTCOME_RETURN, "k", "no transition"),
                           (ex.OUTCOME_TRANSITION, "r", "transition"),
                           (ex.OUTCOME_CENSORED, "0.6", "censored")):
        m = sel & (cm["outcome"] == code)
        text = f"{lab} ({int(m.sum())})"
        if code == ex.OUTCOME_TRANSITION and cut is not None and m.any():
            k = int(np.sum(ex.inside_polygon(cm["r"][m], cm["p_r"][m], cut[1], cut[2])))
            text += f", {k} inside the cut"
        ax1.plot(cm["r"][m], cm["p_r"][m], "o", ms=3.5 if code == ex.OUTCOME_TRANSITION else 2.5,
                 color=col, label=text)
    ax1.set_xlabel("r [cm]")
    ax1.set_ylabel("p_r [cm/s]")
    ax1.set_title(f"(a) synthetic tracks: U1^- crossings with dE in [{lo:g}, {hi:g}) (cm/s)^2", fontsize=10)
    ax1.legend(fontsize=7, loc="upper right")

    ok = b["count"] > 0
    x, f = b["dE_center"][ok], b["fraction"][ok]
    yerr = np.clip(np.array([f - b["ci_low"][ok], b["ci_high"][ok] - f]), 0, None)   # roundoff at k = 0
    ax2.errorbar(x, f, yerr=yerr, xerr=b["dE_err"][ok], fmt="o", color="k", ms=4, capsize=2,
                 label=f"synthetic tracks ({a['confidence']:.0%} Wilson, design effect "
                       f"{a['design_effect']:.2f})")
    top = float(b["dE_high"][-1])
    if th is not None:
        dd = np.linspace(0.0, min(top, float(th.dE[-1])), 300)
        ax2.plot(dd, th.p(dd), "b-", label="A_tube / A_E (tubes)")
        ax2.plot(dd, th.growth_rate * dd, "b:", lw=0.8,
                 label=f"(T_po / A0) dE, T_po/A0 = {th.growth_rate * 1e3:.4f}e-3")
    if math.isfinite(a.get("slope", math.nan)) and math.isfinite(a.get("slope_err", math.nan)):
        dd = np.linspace(0.0, a["fit_max"], 50)
        lab = f"fit to the synthetic tracks, dE <= {a['fit_max']:g}: ({a['slope'] * 1e3:.3f} +- " \
              f"{a['slope_err'] * 1e3:.3f})e-3 (s/cm)^2"
        if "slope_theory" in a:
            lab += f"; theory {a['slope_theory'] * 1e3:.3f}e-3"
        ax2.plot(dd, a["slope"] * dd, "r--", label=lab)
    elif "slope_upper_95" in a:
        ax2.plot([], [], " ", label=f"no transition at dE <= {a['fit_max']:g}: slope < "
                                    f"{a['slope_upper_95'] * 1e3:.3f}e-3 (95 %)")
    if math.isfinite(a.get("inside_fraction", math.nan)):
        ax2.plot([], [], " ", label=f"transitions inside the tube cut at or above their dE: "
                                    f"{a['n_transitions_inside']} of {a['n_inside_evaluated']}")
    ax2.axhline(0, color="0.5", lw=0.5)
    ax2.set_xlim(float(b["dE_low"][0]), top)
    ax2.set_xlabel("dE [(cm/s)^2]")
    ax2.set_ylabel("transition fraction")
    ax2.set_title(f"(b) synthetic tracks: {a['n_crossings']} U1^- crossings, {a['n_transitions']} transitions",
                  fontsize=10)
    ax2.legend(fontsize=7, loc="upper left")
    ax2.grid(True, lw=0.3)
    fig.suptitle("Synthetic tracks (tubes' synthetic_experiment scene, not the paper's data): "
                 + _describe_tracks(tracks_attrs), fontsize=9)
    fig.tight_layout()
    try:
        _output.save_figure(fig, path, dpi=130)
    finally:
        plt.close(fig)


def experiment_figures(result: str, outdir, opt=None, quiet: bool = False) -> list:
    """The experiment figure of a tubes RESULT.h5 with /tracks: analyse the tracks (tubes.experiment,
    options opt or its defaults) against the file's own theory, write DIR/experiment.h5 and draw
    DIR/experiment.png. Returns the paths written; [] (and a one-line note) without /tracks.
    Raises tubes.experiment.ExperimentError when the tracks cannot be analysed."""
    import h5py
    from . import experiment as ex
    with h5py.File(result, "r") as f:
        has_tracks = "tracks" in f
        has_theory = "section" in f and "transition" in f
    if not has_tracks:
        print(f"experiment: {result} has no /tracks (scene synthetic_experiment): figure skipped")
        return []
    out = _output.out_dir(outdir, "-o")
    tracks = ex.read_tracks(result)
    theory = ex.load_theory(result) if has_theory else None
    if theory is None:
        print(f"experiment: {result} has no /section or /transition: the figure has no theory")
    an = ex.analyse(tracks, theory, opt)
    h5 = out / "experiment.h5"
    png = out / "experiment.png"
    with _output.batch():      # both or neither
        ex.write_analysis(str(h5), an, ["python -m tubes.figures", result, "-o", str(outdir)], result)
        plot_experiment(png, an, tracks.attrs)
    if not quiet:
        a = an.attrs
        line = f"experiment (synthetic tracks): {a['n_crossings']} U1^- crossings, {a['n_transitions']} transitions"
        if math.isfinite(a.get("slope_err", math.nan)):
            line += f"; slope ({a['slope'] * 1e3:.3f} +- {a['slope_err'] * 1e3:.3f})e-3 (s/cm)^2"
            if "slope_theory" in a:
                line += f" against {a['slope_theory'] * 1e3:.3f}e-3 (theory, same bins)"
        if math.isfinite(a.get("inside_fraction", math.nan)):
            line += f"; {a['n_transitions_inside']} of {a['n_inside_evaluated']} transitions inside the tube cut"
        print(line)
        if an.report.issues:
            print(f"experiment: {len(an.report.issues)} issue(s) in the tracks "
                  f"(python -m tubes.experiment {result} lists them)")
    return [h5, png]


def main(argv=None) -> int:
    from . import experiment as ex
    args, res, rc = plots.open_result("python -m tubes.figures", __doc__.splitlines()[0], argv)
    if res is None:
        return rc

    def draw():     # every figure and experiment.h5 made first, then written all or none
        nonlocal res
        written = plots._draw_all(res, args.outdir)
        res = None
        return written + experiment_figures(args.result, args.outdir)
    return plots.draw_and_write("python -m tubes.figures", args.result, draw,
                                {ex.ExperimentError: "experiment figure: "})


if __name__ == "__main__":
    raise SystemExit(main())
