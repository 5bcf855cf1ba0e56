"""Transition fractions from tracked trajectories: the experiment of Ross et al. (2018), Sec. IV-V.

    python -m tubes.experiment TRACKS --theory RESULT.h5 -o ANALYSIS.h5 [--figure FIG.png]
                               [--estimator spectral|savgol] [--bins -40:400:40]
                               [--dissipation-figure LOSS.png] [--decay-drift] ...

TRACKS is a CSV file (header ``track,t,x,y``; s and cm) or an HDF5 file with the group /tracks
(datasets track, t, x, y). The pipeline: read and validate the tracks (NaNs, gaps, time order,
short pieces, positions off the plate or energetically impossible: each reported, nothing dropped
silently), drop the first t_skip of every track, estimate velocities (spectral or Savitzky-Golay
differentiation), momenta and energies (tubes.momentum, tubes.energy), locate the crossings of U1
(the ray theta = pi/4, x > 0) on cubic splines, classify every U1^- crossing by its fate (through
the S12 bottleneck before the next U1 crossing, back to U1, or censored), bin by dE, give Wilson
intervals, fit the small-dE slope and compare with the tube theory of a tubes RESULT.h5 (p_trans
and the tube cuts). From the energy's decay along the tracks: the loss against time and against
path length, and which dissipation law the ball follows (viscous damping, rolling resistance,
both), with the coefficients and their intervals (_decay_fits). docs/experiment.md describes
every step, the output and the measured errors.
Units: cm, s; energies per unit mass in (cm/s)^2.
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import datetime
import functools
import io
import json
import math
import os
import pathlib
import re
import sys
import warnings

import numpy as np

from . import (Model, TubesError, energies, energy, equilibria, integrate, momentum, potentials,
               shape_derivatives, vector_field)
from . import _output

PLATE = 15.0            # [cm] half-width of the machined plate: |x|, |y| <= PLATE
T_SKIP = 0.4            # [s] the paper's Lyapunov time, dropped at the start of every track
GATE = 1.5              # [cm] a transition passes x < x_S12 - GATE (as the montecarlo scene)
MIN_DURATION = 1.0      # [s] shortest segment analysed
GAP_FACTOR = 1.5        # a time step > GAP_FACTOR / rate is a gap
ESTIMATORS = ("spectral", "savgol")
# Tuned on synthetic tracks with known truth (tune(); docs/experiment.md, "Tuning"):
DEFAULT_OPTIONS = {"savgol": {"window": 15, "order": 4}, "spectral": {"cutoff": 5.0, "edge": "odd"}}
ENERGY_WINDOW = 1.0     # [s] half-width of the windowed energy regression (tuned likewise)
EDGE = 0.1              # [s] crossings this close to a segment end are not classified
TRIM = 0.2              # [s] samples this close to a segment end stay out of energy windows
DECAY_TRIM = TRIM       # [s] ... and out of the regressions of the energy's decay (_decay_fits)
LAW_PRESENT = 4.0       # a dissipation coefficient more than this many standard errors above 0 is present
ENERGY_BALANCE_TOL = 0.1  # refuse when g H trades with T (median over segments) further than this from 1
SEGMENT_BALANCE_TOL = 0.25  # drop a segment whose own ratio is further than this from 1
MATCH_TOL = 0.1         # [s] two crossings of one branch and track this close are the same one
                        #     (consecutive crossings of one branch are > 0.3 s apart)

OUTCOME_TRANSITION, OUTCOME_RETURN, OUTCOME_CENSORED, OUTCOME_EDGE = 1, 0, -1, -2

# Folding (--fold): maps (x, y) -> M (x, y) that carry the diagonal of one quadrant onto U1, the
# crossings moving one way onto U1^- (towards S12) and the saddle ahead onto S12.  H(x, y) is
# invariant under (x, y) -> (y, x) and (x, y) -> (-x, -y) only: the first four are exact; the other
# four map the surface onto its mirror image (xi -> -xi), whose wells W2, W4 are 486 (cm/s)^2
# shallower (docs/experiment.md, "Folding").  (name, M, quadrant, exact, the saddle ahead)
IMAGES = (
    ("Q1+", ((1, 0), (0, 1)), 1, True, "S12"),       # Q1, counter-clockwise
    ("Q1-", ((0, 1), (1, 0)), 1, True, "S14"),       # Q1, clockwise: the swap
    ("Q3+", ((-1, 0), (0, -1)), 3, True, "S34"),     # Q3, counter-clockwise: the half turn
    ("Q3-", ((0, -1), (-1, 0)), 3, True, "S23"),     # Q3, clockwise
    ("Q2+", ((0, 1), (-1, 0)), 2, False, "S23"),     # Q2, counter-clockwise: a quarter turn
    ("Q2-", ((-1, 0), (0, 1)), 2, False, "S12"),     # Q2, clockwise: x -> -x
    ("Q4+", ((0, -1), (1, 0)), 4, False, "S14"),     # Q4, counter-clockwise: a quarter turn
    ("Q4-", ((1, 0), (0, -1)), 4, False, "S34"),     # Q4, clockwise: y -> -y
)
FOLDS = {"none": (0,), "exact": (0, 1, 2, 3), "all": tuple(range(8))}
FOLD_TEXT = {"none": "U1^-", "exact": "the diagonals of quadrants 1 and 3, both ways",
             "all": "the four diagonals, both ways"}

__all__ = ["ExperimentError", "Tracks", "Issue", "ValidationReport", "Segment", "Theory",
           "read_tracks", "write_tracks_csv", "write_tracks_h5", "validate", "differentiate", "estimate_segment",
           "find_crossings", "analyse", "load_theory", "Calibration", "fit_calibration", "read_calibration",
           "wilson", "fit_slope", "inside_polygon",
           "synthetic_tracks", "tune", "write_analysis", "plot_analysis", "plot_dissipation", "main", "Options",
           "Analysis",
           "window_energy", "classify", "truth_crossings", "noise_estimate", "noise_kinetic_energy"]


class ExperimentError(RuntimeError):
    """Bad input: unreadable or malformed tracks or theory file, no usable data, bad options."""


# --------------------------------------------------------------------------------------------
# Tracks and their validation
# --------------------------------------------------------------------------------------------

@dataclasses.dataclass
class Tracks:
    """Flat arrays, one row per sample (sorted by track then time in the files)."""
    track: np.ndarray                 # (n,) int64 track id
    t: np.ndarray                     # (n,) [s]
    x: np.ndarray                     # (n,) [cm]
    y: np.ndarray                     # (n,) [cm]
    attrs: dict = dataclasses.field(default_factory=dict)   # camera_rate, pixel, noise, ...
    truth: dict | None = None         # state (n, 4), energy (n,), dE (n,): synthetic data only
    source: str = ""


@dataclasses.dataclass
class Issue:
    """One problem found in one track. severity 'warning': samples or a segment were dropped
    and the rest of the track is used; 'error': the whole track was rejected."""
    track: int
    kind: str            # nan, off_plate, jump, gap, time_order, irregular, jitter, short, impossible_height
    severity: str
    t_start: float       # [s] time span concerned
    t_end: float
    n_samples: int       # samples dropped (0 for a gap)
    message: str


KINDS = ("nan", "off_plate", "jump", "impossible_height", "gap", "time_order", "irregular",
         "jitter", "short", "energy_balance")


@dataclasses.dataclass
class ValidationReport:
    """Per-track issues and the counts of the whole file."""
    issues: list = dataclasses.field(default_factory=list)
    n_tracks: int = 0            # tracks in the file
    n_tracks_rejected: int = 0   # tracks rejected as a whole (severity 'error')
    n_samples: int = 0           # samples in the file
    n_samples_skipped: int = 0   # samples in the first t_skip of a track (by design)
    n_samples_used: int = 0      # samples in the analysed segments
    n_segments: int = 0          # analysed segments

    def add(self, *args) -> None:
        self.issues.append(Issue(*args))

    def counts(self) -> dict:
        """kind -> number of issues of that kind."""
        out = {k: 0 for k in KINDS}
        for i in self.issues:
            out[i.kind] = out.get(i.kind, 0) + 1
        return out

    def samples_dropped(self) -> dict:
        """kind -> samples dropped for that reason."""
        out = {k: 0 for k in KINDS}
        for i in self.issues:
            out[i.kind] = out.get(i.kind, 0) + i.n_samples
        return out

    def summary(self) -> str:
        c, d = self.counts(), self.samples_dropped()
        lines = [f"tracks: {self.n_tracks} read, {self.n_tracks_rejected} rejected; samples: "
                 f"{self.n_samples} read, {self.n_samples_skipped} in the first t_skip, "
                 f"{self.n_samples_used} analysed in {self.n_segments} segments"]
        kinds = [k for k in c if c[k]]
        if kinds:
            lines.append("issues: " + ", ".join(f"{k} {c[k]} ({d[k]} samples)" for k in kinds))
        return "\n".join(lines)


@dataclasses.dataclass
class Segment:
    """A piece of one track with valid, regularly sampled data."""
    track: int
    index: np.ndarray    # rows of the flat arrays
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray


TIME_UNITS = {"s": 1.0, "ms": 1.0e-3, "us": 1.0e-6}          # -> s
TIME_UNIT_CHOICES = (*TIME_UNITS, "frame")                      # frame: frame index / --rate -> s
FRAME_NAMES = ("frame", "frames", "frame_number", "framenumber", "frame_no", "frame_index", "frame_id",
               "image", "image_number", "slice")               # a time column by these names counts frames
SURFACE_PARAMS = ("alpha", "beta", "gamma", "xi", "h0", "g")   # the surface and gravity of a track file
CAL_RESIDUAL_MAX = 0.5   # [cm] a fitted calibration worse than this is refused
LENGTH_UNITS = {"cm": 1.0, "mm": 0.1, "m": 100.0, "px": None}   # -> cm (px: --pixel-size)


# Numbers in a tracks or calibration file and in the options: ASCII digits only. Python's float()
# and int() also take other scripts' digits ('\u0661' Arabic-Indic, '\uff11' full-width) and
# underscores ('1_000'): a file holding them is refused (file, line, column), not read as numbers.
_ASCII_FLOAT = re.compile(r"[+-]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|nan|inf|infinity)",
                          re.IGNORECASE | re.ASCII)
_ASCII_INT = re.compile(r"[+-]?[0-9]+", re.ASCII)
ASCII_NUMBER = "ASCII digits 0-9 with an optional sign, '.' and exponent, e.g. -1.25e3"


def _ascii_float(s: str) -> float:
    """float(s) for a number written in ASCII (ASCII_NUMBER; spaces and tabs around it); ValueError
    otherwise."""
    t = s.strip(" \t\r\n")
    if not _ASCII_FLOAT.fullmatch(t):
        raise ValueError(f"{s!r} is not a number in {ASCII_NUMBER}")
    return float(t)


def _sniff_delimiter(path: str) -> str | None:
    """The separator of a tracks file, from its first line that is not a comment: ',', ';', a tab,
    or None (runs of spaces)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.strip() and not line.lstrip().startswith("#"):
                    counts = {d: line.count(d) for d in (",", ";", "\t")}
                    best = max(counts, key=counts.get)
                    return best if counts[best] > 0 else None
    except OSError:
        return ","
    return ","


class _SpaceDialect(csv.Dialect):
    delimiter = " "
    skipinitialspace = True
    quotechar = '"'
    doublequote = True
    lineterminator = "\n"
    quoting = csv.QUOTE_MINIMAL


def _check_columns(columns: dict) -> None:
    """--columns: each of track, t, x, y read from its own column of the file (a role without a
    name keeps its own name: x=t would read the times twice)."""
    names = {}
    for c in ("track", "t", "x", "y"):
        v = str(columns.get(c, c)).strip().lower()
        if v in names:
            given = ", ".join(f"{k}={columns[k]}" if k in columns else f"{k} (its default name)"
                              for k in (names[v], c))
            raise ExperimentError(f"--columns: the column {v!r} is named for two roles, {given}: each of "
                                  "track, t, x, y needs its own column")
        names[v] = c


def _read_csv(path: str, columns: dict | None = None) -> Tracks:
    cols = {"track": [], "t": [], "x": [], "y": []}
    names = {c: (columns or {}).get(c, c).strip().lower() for c in cols}
    try:
        f = open(path, newline="", encoding="utf-8")
    except OSError as exc:
        raise ExperimentError(f"{path}: cannot open ({exc.strerror})") from exc
    delim = _sniff_delimiter(path)
    try:
        with f:
            header, lineno = _read_csv_rows(path, f, cols, names, delim)
    except UnicodeDecodeError as exc:
        raise ExperimentError(f"{path}: not UTF-8 text (byte {exc.object[exc.start]:#04x} at offset "
                              f"{exc.start} of a block): a CSV file of tracks is text") from None
    except csv.Error as exc:
        raise ExperimentError(f"{path}: not a CSV file ({exc})") from None
    if header is None:
        raise ExperimentError(f"{path}: empty file (expected the header track,t,x,y)")
    if not cols["t"]:
        raise ExperimentError(f"{path}: no samples after the header")
    return Tracks(np.asarray(cols["track"], dtype=np.int64), np.asarray(cols["t"], float),
                  np.asarray(cols["x"], float), np.asarray(cols["y"], float), {}, None, path)


def _read_csv_rows(path: str, f, cols: dict, names: dict, delim: str | None):
    """The rows of an open CSV file into cols (the file's column names[c] for column c);
    returns (header, last line number)."""
    rows = csv.reader(f, delimiter=delim) if delim else csv.reader(f, _SpaceDialect())
    header = None
    lineno = 0
    pos = {}
    for lineno, row in enumerate(rows, start=1):
        if not row or (row[0].strip().startswith("#")) or all(not c.strip() for c in row):
            continue
        if header is None:
            header = [c.strip().lower() for c in row]
            missing = [names[c] for c in ("track", "t", "x", "y") if names[c] not in header]
            if missing:
                raise ExperimentError(
                    f"{path}:{lineno}: the header must name the columns "
                    f"{','.join(names[c] for c in ('track', 't', 'x', 'y'))}; got {','.join(row)} "
                    f"(missing {', '.join(missing)}); map other names with --columns "
                    f"track=NAME,t=NAME,x=NAME,y=NAME")
            pos = {c: header.index(names[c]) for c in ("track", "t", "x", "y")}
            continue
        if len(row) != len(header):
            raise ExperimentError(f"{path}:{lineno}: {len(row)} fields, the header has "
                                  f"{len(header)}")
        for c in ("track", "t", "x", "y"):
            s = row[pos[c]].strip(" \t\r\n")
            where = f"{path}:{lineno}: column {c!r} (field {pos[c] + 1})"
            if c == "track":
                try:
                    v = _ascii_float(s)
                except ValueError:
                    v = math.nan
                if not (math.isfinite(v) and v == int(v) and abs(v) < 2.0**53):
                    raise ExperimentError(f"{where}: {s!r} is not an integer track id (|id| < 2^53, "
                                          f"{ASCII_NUMBER})")
                cols[c].append(int(v))
            else:
                if s == "":
                    cols[c].append(math.nan)    # a lost frame: reported as NaN
                    continue
                try:
                    cols[c].append(_ascii_float(s))
                except ValueError:
                    raise ExperimentError(f"{where}: cannot read {s!r} as a number: allowed "
                                          f"{ASCII_NUMBER}") from None
    return header, lineno


def _dtype_text(dt) -> str:
    kind = {"S": "byte strings", "U": "strings", "O": "strings (variable length)", "b": "booleans",
            "c": "complex numbers", "V": "compound or opaque records", "f": "reals", "i": "integers",
            "u": "integers", "M": "dates", "m": "time deltas"}
    return f"{kind.get(dt.kind, 'values')} (dtype {dt})"


def _read_h5(path: str) -> Tracks:
    import h5py
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ExperimentError(f"{path}: not a readable HDF5 file ({exc})") from exc
    try:
        with f:
            return _read_h5_tracks(path, f, h5py)
    except (OSError, RuntimeError, KeyError, ValueError) as exc:   # h5py on a damaged file or an unknown type
        raise ExperimentError(f"{path}: a damaged HDF5 file ({exc})") from None


def _read_h5_tracks(path: str, f, h5py) -> Tracks:
    if "tracks" not in f or not isinstance(f["tracks"], h5py.Group):
        raise ExperimentError(f"{path}: no group /tracks (expected datasets track, t, x, y)")
    g = f["tracks"]
    arrs = {}
    for c in ("track", "t", "x", "y"):
        if c not in g or not isinstance(g[c], h5py.Dataset):
            raise ExperimentError(f"{path}: /tracks has no dataset {c!r}")
        d = g[c]
        if d.dtype.kind not in "iuf":
            raise ExperimentError(
                f"{path}: /tracks/{c} holds {_dtype_text(d.dtype)}: it must hold "
                + ("integer track ids (int32, int64, or reals with integer values)" if c == "track" else
                   f"real numbers (float64, {'s' if c == 't' else 'cm'}; integers allowed)"))
        if len(d.shape) != 1:
            raise ExperimentError(f"{path}: /tracks/{c} must be one-dimensional, shape {d.shape}")
        a = np.asarray(d[()])
        arrs[c] = a
    n = arrs["t"].size
    for c in arrs:
        if arrs[c].size != n:
            raise ExperimentError(f"{path}: /tracks/{c} has {arrs[c].size} values, /tracks/t {n}")
    if n == 0:
        raise ExperimentError(f"{path}: /tracks is empty")
    tr = arrs["track"]
    if tr.dtype.kind == "f":
        if not np.all(np.isfinite(tr)) or np.any(tr != np.round(tr)):
            raise ExperimentError(f"{path}: /tracks/track must hold integer track ids")
    elif tr.dtype.kind not in "iu":
        raise ExperimentError(f"{path}: /tracks/track must hold integer track ids")
    attrs = {k: (v.decode() if isinstance(v, bytes) else (v.item() if isinstance(v, np.generic) else v))
             for k, v in g.attrs.items()}
    if "model" in f:   # a tubes file: the surface the tracks were made on (checked against a theory)
        m = f["model"].attrs
        sysname = m.get("system", b"rolling_ball")
        sysname = sysname.decode() if isinstance(sysname, bytes) else str(sysname)
        attrs["surface_model"] = json.dumps(
            {"system": sysname, **{k: float(m[k]) for k in SURFACE_PARAMS if k in m}})
    truth = None
    if "truth" in g:
        t = g["truth"]
        truth = {k: np.asarray(t[k][()]) for k in ("state", "energy", "dE") if k in t}
        if "state" not in truth or truth["state"].shape != (n, 4):
            truth = None
    return Tracks(tr.astype(np.int64), arrs["t"].astype(float), arrs["x"].astype(float),
                  arrs["y"].astype(float), attrs, truth, path)


@dataclasses.dataclass
class Calibration:
    """Camera to surface coordinates, after the length unit: subtract the plate centre's camera
    position (origin), flip y if the camera's y axis points down, rotate by angle [deg]
    counter-clockwise: (x, y)_surface = R(angle) (x - ox, s (y - oy)), s = -1 if flip_y."""
    origin: tuple = (0.0, 0.0)        # [cm] the plate centre in the camera frame
    angle: float = 0.0                # [deg]
    flip_y: bool = False
    residual: float = math.nan        # [cm] rms of a fitted calibration's known points
    n_points: int = 0

    def apply(self, x, y):
        a = math.radians(self.angle)
        u = np.asarray(x, float) - self.origin[0]
        v = (np.asarray(y, float) - self.origin[1]) * (-1.0 if self.flip_y else 1.0)
        return math.cos(a) * u - math.sin(a) * v, math.sin(a) * u + math.cos(a) * v

    def describe(self) -> str:
        s = (f"calibration: origin ({self.origin[0]:.4g}, {self.origin[1]:.4g}) cm, rotation {self.angle:.4g} deg"
             f"{', y flipped' if self.flip_y else ''}")
        if self.n_points:
            s += f"; fitted to {self.n_points} known points, residual rms {self.residual:.3g} cm"
        return s


def fit_calibration(camera, surface, length_unit: str = "cm", pixel_size: float | None = None) -> Calibration:
    """The rotation, origin and y flip taking known camera points (n, 2; in length_unit) to their
    surface positions (n, 2) [cm], n >= 2: least squares (Procrustes, the scale fixed by the
    units), with and without the flip; the better fit is kept and its rms residual reported."""
    cam, srf = np.asarray(camera, float), np.asarray(surface, float)
    for name, a in (("camera", cam), ("surface", srf)):
        if a.ndim != 2 or a.shape[1] != 2:     # (2, n) would be read as other points if reshaped
            raise ExperimentError(f"calibration: {name} points must have shape (n, 2), one point (x, y) per row: "
                                  f"got shape {a.shape}")
    cam = cam * _length_scale(length_unit, pixel_size)
    if cam.shape[0] < 3 or cam.shape != srf.shape or not (np.all(np.isfinite(cam)) and np.all(np.isfinite(srf))):
        raise ExperimentError("calibration: need at least three finite known points, not on one line "
                              f"(camera x, y; surface x, y): got {min(cam.shape[0], srf.shape[0])}")
    for name, a in (("camera", cam), ("surface", srf)):
        rank = _point_rank(a)
        if rank < 2:
            raise ExperimentError(
                f"calibration: the {name} points {'coincide' if rank == 0 else 'lie on one line'} (rank {rank} of "
                f"2, {cam.shape[0]} points): the rotation and the y flip cannot be fitted; give at least three "
                "known points not on one line (e.g. three or four of the wells)")
    best = None
    for flip in (False, True):
        c = cam * np.array([1.0, -1.0 if flip else 1.0])
        cm_, sm = c.mean(0), srf.mean(0)
        h = (c - cm_).T @ (srf - sm)
        ang = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])          # 2-D Procrustes rotation
        r = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
        origin = cm_ - r.T @ sm                                           # R (c - o) = s
        res = float(np.sqrt(np.mean(np.sum((((c - origin) @ r.T) - srf) ** 2, axis=1))))
        raw = (float(origin[0]), float(origin[1]) * (-1.0 if flip else 1.0))   # in the file's frame
        cal = Calibration(raw, math.degrees(ang), flip, res, cam.shape[0])
        if best is None or res < best.residual - 1e-12:
            best = cal
    return best


CAL_RANK_TOL = 1e-6   # points whose spread across their best line is below this fraction of its length: collinear


def _point_rank(a) -> int:
    """The rank of points (n, 2) about their mean: 0 (one point), 1 (on a line) or 2; spreads
    [cm] below 1e-9 cm, or the smaller below CAL_RANK_TOL times the larger, count as none."""
    sv = np.linalg.svd(a - a.mean(0), compute_uv=False)
    if not sv[0] > 1e-9:
        return 0
    return 1 if not sv[1] > CAL_RANK_TOL * sv[0] else 2


CAL_HEADER = ("camera_x", "camera_y", "surface_x", "surface_y")   # each name may end in _UNIT


def _check_calibration_header(path: str, n: int, cells: list, length_unit: str) -> None:
    """A calibration file's header line: the four names of CAL_HEADER in that order, each
    optionally with a unit (camera_x_mm); a camera unit must be length_unit, a surface unit cm."""
    want = ",".join(CAL_HEADER)
    names = [c.lower() for c in cells]
    ok = len(names) == 4 and all(re.fullmatch(rf"{w}(_[a-z]+)?", c) for w, c in zip(CAL_HEADER, names))
    if not ok:
        raise ExperimentError(f"{path}:{n}: the header must be {want} (each name may end in a unit, e.g. "
                              f"camera_x_mm); got {','.join(cells)!s}")
    units = [c[len(w) + 1:] for w, c in zip(CAL_HEADER, names)]
    for w, u in zip(CAL_HEADER[:2], units[:2]):
        if u and u in LENGTH_UNITS and u != length_unit:
            raise ExperimentError(f"{path}:{n}: the column {w}_{u} is in {u}, the lengths are read in {length_unit}: "
                                  f"give --length-unit {u}, or the header {w}_{length_unit}")
    for w, u in zip(CAL_HEADER[2:], units[2:]):
        if u and u != "cm":
            raise ExperimentError(f"{path}:{n}: the column {w}_{u}: surface positions are in cm ({w} or {w}_cm)")


def read_calibration(path: str, length_unit: str = "cm", pixel_size: float | None = None) -> Calibration:
    """A calibration file: CSV rows camera_x,camera_y,surface_x,surface_y of known points (for
    example the wells where damped balls come to rest), a header line allowed; fitted."""
    rows = []
    header = False
    try:
        with open(path, newline="", encoding="utf-8") as f:
            for n, line in enumerate(f, 1):
                cells = [c.strip() for c in line.replace(";", ",").split(",")]
                if not line.strip() or line.lstrip().startswith("#"):
                    continue
                try:
                    rows.append([_ascii_float(c) for c in cells])
                except ValueError:
                    if rows or header:
                        raise ExperimentError(f"{path}:{n}: not four numbers ({ASCII_NUMBER}): "
                                              f"{line.strip()!r}") from None
                    _check_calibration_header(path, n, cells, length_unit)
                    header = True
                    continue
                if len(rows[-1]) != 4:
                    raise ExperimentError(f"{path}:{n}: need camera_x,camera_y,surface_x,surface_y")
    except OSError as exc:
        raise ExperimentError(f"{path}: cannot read the calibration file ({exc.strerror})") from exc
    except UnicodeDecodeError as exc:
        raise ExperimentError(f"{path}: not UTF-8 text (byte {exc.object[exc.start]:#04x}): a calibration file "
                              "is text") from None
    a = np.array(rows, float).reshape(-1, 4)    # rows of four (checked above), or none
    return fit_calibration(a[:, :2], a[:, 2:], length_unit, pixel_size)


def _length_scale(length_unit: str, pixel_size: float | None) -> float:
    if length_unit not in LENGTH_UNITS:
        raise ExperimentError(f"length unit {length_unit!r}: allowed {', '.join(LENGTH_UNITS)}")
    if pixel_size is not None and length_unit != "px":
        raise ExperimentError(f"--pixel-size {pixel_size:g} is for lengths in pixels (--length-unit px), but the "
                              f"lengths are read in {length_unit} (--length-unit {length_unit}): give one of the two")
    if length_unit == "px":
        if not (pixel_size is not None and math.isfinite(pixel_size) and pixel_size > 0):
            raise ExperimentError("length unit px needs --pixel-size (cm per pixel, > 0)")
        return pixel_size
    return LENGTH_UNITS[length_unit]


def _looks_like_frames(t: np.ndarray, track: np.ndarray) -> bool:
    """Times that are frame indices: all integers, increasing within a track in steps that are
    whole multiples of the most common step 1 (a frame index read as seconds: 1 Hz)."""
    ok = np.isfinite(t)
    t, track = t[ok], track[ok]
    if t.size < 3 or not np.all(t == np.round(t)):
        return False
    d = np.diff(t)[np.diff(track) == 0]
    d = d[d > 0]
    return d.size > 0 and float(np.median(d)) == 1.0


def read_tracks(path: str, columns: dict | None = None, time_unit: str = "s",
                length_unit: str = "cm", pixel_size: float | None = None,
                calibration: Calibration | None = None, rate: float | None = None) -> Tracks:
    """Read a CSV (header track,t,x,y, or the names given in columns = {'track': ..., 't': ...,
    'x': ..., 'y': ...}; separated by ',', ';', tabs or spaces) or HDF5 (/tracks) file of tracked
    positions, with times in time_unit (s, ms, us, or frame: frame indices, divided by rate in
    frames per second, which is then required) and lengths in length_unit (cm, mm, m, or px
    with pixel_size in cm per pixel). Returned in s and cm, sorted by track, then time, whatever
    the rows' order in the file; calibration, if given, maps camera to surface coordinates.
    A time column that looks like frame indices (named frame, ..., or integers in steps of 1
    read as seconds) is refused unless time_unit is frame."""
    p = pathlib.Path(path)
    if not p.exists():
        raise ExperimentError(f"{path}: no such file")
    if time_unit not in TIME_UNIT_CHOICES:
        raise ExperimentError(f"time unit {time_unit!r}: allowed {', '.join(TIME_UNIT_CHOICES)}")
    if time_unit == "frame" and not (rate is not None and math.isfinite(rate) and rate > 0):
        raise ExperimentError("time unit frame (times are frame indices) needs --rate: the camera's frames "
                              "per second (> 0), by which the frame indices are divided")
    lscale = _length_scale(length_unit, pixel_size)
    if calibration is not None and not (np.all(np.isfinite(calibration.origin)) and math.isfinite(calibration.angle)):
        raise ExperimentError(f"calibration: origin {calibration.origin} and rotation {calibration.angle} deg must be "
                              "finite numbers (--origin, --rotate)")
    if columns:
        _check_columns(columns)
    with open(p, "rb") as f:
        magic = f.read(8)
    tr = _read_h5(path) if magic == b"\x89HDF\r\n\x1a\n" else _read_csv(path, columns)
    tname = str((columns or {}).get("t", "t")).strip()
    if time_unit == "frame":
        tr.t = tr.t / rate
        tr.attrs = dict(tr.attrs, camera_rate=rate)
    else:
        named = tname.lower() in FRAME_NAMES
        if named or time_unit == "s" and _looks_like_frames(tr.t, tr.track):
            why = (f"is named {tname!r}" if named else
                   f"{tname!r} holds integers in steps of 1 (a camera at 1 Hz if read as seconds)")
            raise ExperimentError(f"{path}: the time column {why}: it looks like frame indices, not times in "
                                  f"{time_unit}: give --time-unit frame --rate R (R the camera's frames per "
                                  "second)")
    if TIME_UNITS.get(time_unit, 1.0) != 1.0:
        tr.t = tr.t * TIME_UNITS[time_unit]
    if lscale != 1.0:
        tr.x = tr.x * lscale
        tr.y = tr.y * lscale
    if calibration is not None:
        tr.x, tr.y = calibration.apply(tr.x, tr.y)
    # rows grouped by track and sorted by time within it (a file may list its rows in any order),
    # except a track whose time decreases over most of its rows in the file's order: a reversed or
    # negated time column, which sorting would turn into a ball gaining energy (its damping biased,
    # nothing said); it keeps the file's order, so that the check rejects it (time_order)
    order = np.argsort(tr.track, kind="stable")
    bounds = np.flatnonzero(np.diff(tr.track[order])) + 1
    for a, b in zip(np.r_[0, bounds], np.r_[bounds, order.size]):
        idx = order[a:b]
        dt = np.diff(tr.t[idx])
        if not np.count_nonzero(dt < 0) > dt.size / 2:
            order[a:b] = idx[np.argsort(tr.t[idx], kind="stable")]
    moved = int(np.count_nonzero(order != np.arange(order.size)))
    if moved:
        tr.track, tr.t, tr.x, tr.y = tr.track[order], tr.t[order], tr.x[order], tr.y[order]
        if tr.truth:
            tr.truth = {k: np.asarray(v)[order] for k, v in tr.truth.items()}
    tr.attrs = dict(tr.attrs, time_unit=time_unit, length_unit=length_unit, rows_reordered=moved)
    return tr


def write_tracks_csv(path: str, tr: Tracks) -> None:
    """Write tracks as CSV (header track,t,x,y)."""
    text = "track,t,x,y\n" + "".join(f"{k},{t:.6f},{x:.6f},{y:.6f}\n"
                                      for k, t, x, y in zip(tr.track, tr.t, tr.x, tr.y))
    _output.emit(path, text.encode("utf-8"))     # the writer rule: FILE.tmp.<pid>, renamed


def write_tracks_h5(path: str, tr: Tracks) -> None:
    """Write tracks in the HDF5 layout read_tracks reads (the synthetic_experiment scene's):
    /tracks/{track, t, x, y}, its attributes, and /tracks/truth when tr.truth is set."""
    def fill(f):
        g = f.create_group("tracks")
        for k, u in (("track", "1"), ("t", "s"), ("x", "cm"), ("y", "cm")):
            d = g.create_dataset(k, data=getattr(tr, k))
            d.attrs["units"] = u
        for k, v in tr.attrs.items():
            g.attrs[k] = v
        if tr.truth is not None:
            h = g.create_group("truth")
            for k, v in tr.truth.items():
                h.create_dataset(k, data=v)
    _output.emit(path, _output.h5_image(fill))   # made in memory, written by the writer rule


def _runs(mask: np.ndarray):
    """(start, stop) of the runs of True in mask."""
    m = np.concatenate([[False], mask, [False]]).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]))


def _jump_flags(t: np.ndarray, x: np.ndarray, y: np.ndarray, tol: float) -> np.ndarray:
    """Glitches: samples that deviate by more than tol [cm] from the cubic through their 4
    neighbours (at the neighbours' times), the largest first, repeated (so a glitch flags itself,
    not its neighbours); flags closer than 6 samples to each other are joined with everything
    between them (an excursion of the tracker rather than an isolated glitch)."""
    n = x.size
    bad = np.zeros(n, bool)
    if n < 5:
        return bad
    for _ in range(max(1, n // 5)):
        good = np.nonzero(~bad)[0]
        if good.size < 5:
            break
        tt, xs, ys = t[good], x[good], y[good]
        nb = [tt[:-4], tt[1:-3], tt[3:-1], tt[4:]]
        c = tt[2:-2]
        px = np.zeros(c.size)
        py = np.zeros(c.size)
        for j, (tj, xj, yj) in enumerate(zip(nb, (xs[:-4], xs[1:-3], xs[3:-1], xs[4:]),
                                             (ys[:-4], ys[1:-3], ys[3:-1], ys[4:]))):
            w = np.ones(c.size)
            for m, tm in enumerate(nb):
                if m != j:
                    w *= (c - tm) / (tj - tm)
            px += w * xj
            py += w * yj
        dev = np.hypot(xs[2:-2] - px, ys[2:-2] - py)
        k = int(np.argmax(dev))
        if dev[k] <= tol:
            break
        bad[good[k + 2]] = True
    f = np.nonzero(bad)[0]
    for i, j in zip(f[:-1], f[1:]):
        if j - i < 6:
            bad[i:j + 1] = True
    return bad


def validate(tracks: Tracks, rate: float, t_skip: float = T_SKIP, plate: float = PLATE,
             min_samples: int = 50, jump_tol: float = 1.0):
    """Split the tracks into analysable segments; returns (segments, report).

    Per track: samples with a NaN are dropped (kind nan); times must increase strictly (a
    repeated or decreasing time rejects the track: time_order; a step below 0.5/rate: irregular);
    positions with |x| or |y| > plate are dropped (off_plate), and so are single-sample jumps
    larger than jump_tol from the cubic through the 4 neighbours (jump); steps > 1.5/rate split
    the track (gap); the first t_skip after the track's first sample is dropped; pieces shorter
    than min_samples are dropped (short). Every drop is an Issue; the energetic check on the
    segments' heights comes later (estimate_segment, analyse)."""
    rep = ValidationReport()
    rep.n_samples = int(tracks.t.size)
    ids, first = np.unique(tracks.track, return_index=True)
    ids = ids[np.argsort(first)]
    rep.n_tracks = int(ids.size)
    segs = []
    dt0 = 1.0 / rate
    for k in ids:
        idx = np.nonzero(tracks.track == k)[0]
        t, x, y = tracks.t[idx], tracks.x[idx], tracks.y[idx]
        k = int(k)
        nan = ~(np.isfinite(t) & np.isfinite(x) & np.isfinite(y))
        if nan.any():
            for a, b in _runs(nan):
                tt = t[a:b][np.isfinite(t[a:b])]
                rep.add(k, "nan", "warning", float(tt.min()) if tt.size else math.nan,
                        float(tt.max()) if tt.size else math.nan, int(b - a),
                        f"track {k}: {b - a} sample(s) with NaN (rows {idx[a]}..{idx[b - 1]}) dropped")
        keep = ~np.isnan(t)
        tk = t[keep]
        if tk.size == 0:
            rep.n_tracks_rejected += 1
            rep.add(k, "nan", "error", math.nan, math.nan, int(idx.size),
                    f"track {k}: no sample with a finite time: track rejected")
            continue
        d = np.diff(tk)
        if np.any(d <= 0):
            j = int(np.argmax(d <= 0))
            what = "repeated" if d[j] == 0 else "decreasing"
            rep.n_tracks_rejected += 1
            rep.add(k, "time_order", "error", float(tk[0]), float(tk[-1]), int(idx.size),
                    f"track {k}: {what} time at t = {tk[j + 1]:.6g} s (after {tk[j]:.6g} s; "
                    f"{int(np.sum(d <= 0))} such step(s)): times must increase within a track; "
                    f"track rejected")
            continue
        if np.any(d < 0.5 * dt0):
            j = int(np.argmax(d < 0.5 * dt0))
            rep.n_tracks_rejected += 1
            rep.add(k, "irregular", "error", float(tk[0]), float(tk[-1]), int(idx.size),
                    f"track {k}: time step {d[j]:.3g} s at t = {tk[j]:.6g} s is below half the "
                    f"camera period {dt0:.3g} s: track rejected")
            continue
        ok = ~nan
        off = ok & ((np.abs(x) > plate) | (np.abs(y) > plate))
        if off.any():
            for a, b in _runs(off):
                rep.add(k, "off_plate", "warning", float(t[a]), float(t[b - 1]), int(b - a),
                        f"track {k}: {b - a} sample(s) off the plate (|x| or |y| > {plate:g} cm, "
                        f"e.g. ({x[a]:.3g}, {y[a]:.3g})) at t = {t[a]:.6g}..{t[b - 1]:.6g} s dropped")
            ok &= ~off
        # regular sampling: split at gaps; then isolated jumps within each gap-free piece
        tstart = float(np.nanmin(t))
        pieces = []
        for a, b in _runs(ok):
            ii = np.arange(a, b)
            cuts = np.nonzero(np.diff(t[ii]) > GAP_FACTOR * dt0)[0]
            for c in cuts:
                rep.add(k, "gap", "warning", float(t[ii[c]]), float(t[ii[c + 1]]), 0,
                        f"track {k}: gap of {t[ii[c + 1]] - t[ii[c]]:.3g} s after t = {t[ii[c]]:.6g} s: "
                        f"track split")
            for pc in np.split(ii, cuts + 1):
                jf = _jump_flags(t[pc], x[pc], y[pc], jump_tol)
                for a2, b2 in _runs(jf):
                    ta, tb = float(t[pc[a2]]), float(t[pc[b2 - 1]])
                    what = (f"sample at t = {ta:.6g} s jumps" if b2 - a2 == 1 else
                            f"{b2 - a2} samples at t = {ta:.6g}..{tb:.6g} s jump")
                    rep.add(k, "jump", "warning", ta, tb, int(b2 - a2),
                            f"track {k}: {what} more than {jump_tol:g} cm off the track: dropped")
                pieces += [pc[a2:b2] for a2, b2 in _runs(~jf)]
        for pc in pieces:
            sk = t[pc] < tstart + t_skip - 1e-9 * max(1.0, abs(tstart))
            rep.n_samples_skipped += int(sk.sum())
            pc = pc[~sk]
            if pc.size == 0:
                continue
            if pc.size < min_samples:
                rep.add(k, "short", "warning", float(t[pc[0]]), float(t[pc[-1]]), int(pc.size),
                        f"track {k}: segment t = {t[pc[0]]:.6g}..{t[pc[-1]]:.6g} s has {pc.size} "
                        f"samples, fewer than the {min_samples} needed: dropped")
                continue
            dd = np.diff(t[pc])
            if dd.size and np.max(np.abs(dd - np.median(dd))) > 0.05 * np.median(dd):
                rep.add(k, "jitter", "warning", float(t[pc[0]]), float(t[pc[-1]]), 0,
                        f"track {k}: time steps vary by up to "
                        f"{np.max(np.abs(dd - np.median(dd))) / np.median(dd):.0%} of the median "
                        f"in t = {t[pc[0]]:.6g}..{t[pc[-1]]:.6g} s; treated as uniform")
            segs.append(Segment(k, idx[pc], t[pc].copy(), x[pc].copy(), y[pc].copy()))
    rep.n_segments = len(segs)
    rep.n_samples_used = int(sum(s.t.size for s in segs))
    return segs, rep


# --------------------------------------------------------------------------------------------
# Differentiation, momenta and energies
# --------------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=32)
def savgol_matrices(window: int, order: int):
    """Savitzky-Golay evaluation rows: (smooth, deriv) of shape (window, window); row j gives the
    value (derivative per sample) at offset j - window//2 of the least-squares polynomial of the
    given order through the window's samples."""
    h = window // 2
    k = np.arange(-h, h + 1, dtype=float)
    A = np.vander(k, order + 1, increasing=True)
    P = np.linalg.pinv(A)                                   # coefficients = P @ samples
    Vs = np.vander(k, order + 1, increasing=True)
    Vd = np.zeros_like(Vs)
    Vd[:, 1:] = Vs[:, :-1] * np.arange(1, order + 1)
    return Vs @ P, Vd @ P


def differentiate(x, dt: float, method: str = "spectral", **options):
    """(velocity, smoothed position) of uniformly sampled x ((n,) or (n, k)): tubes.differentiate,
    the Fortran estimators of src/experiment/tubes_differentiate.f90."""
    import tubes
    if method not in ESTIMATORS:
        raise ExperimentError(f"unknown estimator {method!r}; allowed: {', '.join(ESTIMATORS)}")
    fn = getattr(tubes, "differentiate", None)
    if fn is None:      # the package predates tubes.differentiate: rebuild (make)
        raise ExperimentError("tubes.differentiate is missing: rebuild tubes (make)")
    try:
        v, sm = fn(np.asarray(x, dtype=np.float64), dt, method=method, **options)
    except (TypeError, ValueError) as exc:
        raise ExperimentError(f"estimator {method} {options}: {exc}") from None
    except TubesError as exc:
        raise ExperimentError(f"estimator {method} {options} on {np.shape(x)[0]} samples: {exc}") from None
    return np.asarray(v, float), np.asarray(sm, float)


def differentiator_name() -> str:
    return "tubes.differentiate (src/experiment/tubes_differentiate.f90)"


def min_samples_for(method: str, options: dict) -> int:
    """Fewest samples the estimator needs (besides MIN_DURATION)."""
    if method == "savgol":
        return 2 * int(options.get("window", 15)) + 1
    return 16


def surface_derivatives(x, y, model: Model = Model()):
    """grad H (2, n) and Hess H (2, 2, n) of the ball's surface at the points (x, y), by the core
    (tubes.shape_derivatives: the model's one definition)."""
    q = np.stack([np.asarray(x, float).ravel(), np.asarray(y, float).ravel()], axis=1)
    return shape_derivatives(q, model)


def state_energy(x, y, vx, vy, model: Model = Model()):
    """Momenta and energy at each sample, by tubes.momentum and tubes.energies (each one call to
    the core for all the samples). Returns px, py, E, T with T = p.v / 2 (T is quadratic in v)."""
    x, y, vx, vy = (np.asarray(a, float).ravel() for a in (x, y, vx, vy))
    p = momentum(np.stack([x, y], axis=1), np.stack([vx, vy], axis=1), model)
    px, py = p[:, 0].copy(), p[:, 1].copy()
    E = energies(np.stack([x, y, px, py], axis=1), model)
    T = 0.5 * (px * vx + py * vy)
    return px, py, E, T


def energy_of_states(states, model: Model = Model()) -> np.ndarray:
    """tubes' energy of each row (x, y, px, py) of states [(cm/s)^2]."""
    return energies(np.asarray(states, float), model)


def potential_energy(x, y, model: Model = Model()) -> np.ndarray:
    """g H(x, y) [(cm/s)^2] at each point (tubes' energy at rest)."""
    return potentials(np.stack([np.asarray(x, float), np.asarray(y, float)], axis=1), model)


def estimate_segment(seg: Segment, method: str, options: dict, model: Model) -> dict:
    """Smoothed positions, velocities, momenta, energy E and kinetic energy T along a segment,
    and dE/dq at fixed velocity (for the error propagation)."""
    dt = float(np.median(np.diff(seg.t)))
    vx, xs = differentiate(seg.x, dt, method, **options)
    vy, ys = differentiate(seg.y, dt, method, **options)
    px, py, E, T = state_energy(xs, ys, vx, vy, model)
    gr, hs = surface_derivatives(xs, ys, model)
    gv = gr[0] * vx + gr[1] * vy
    # E = (7/10)(|v|^2 + (grad H . v)^2) + g H:  dE/dq = (7/5)(grad H . v) Hess v + g grad H
    fq = np.array([1.4 * gv * (hs[0, 0] * vx + hs[0, 1] * vy) + model.g * gr[0],
                   1.4 * gv * (hs[1, 0] * vx + hs[1, 1] * vy) + model.g * gr[1]])
    return {"t": seg.t, "dt": dt, "x": xs, "y": ys, "vx": vx, "vy": vy, "px": px, "py": py,
            "E": E, "T": T, "dEdq": fq, "gradH": gr, "method": method, "options": dict(options)}


@functools.lru_cache(maxsize=16)
def _velocity_noise_gain(dt: float, method: str, options: str) -> float:
    """The variance of an estimated velocity component per unit variance of white position noise
    [1/s^2] (the estimator is linear): the estimator (options as JSON) applied to 16 series of
    4096 standard normal samples (a fixed seed: the analysis' own random numbers are not drawn),
    over their samples more than 64 from the ends."""
    z = np.random.default_rng(20180214).normal(size=(4096, 16))
    v, _ = differentiate(z, dt, method, **json.loads(options))
    return float(np.mean(v[64:-64] ** 2))


def noise_kinetic_energy(est: dict, sigma: float) -> np.ndarray:
    """The mean that white position noise of standard deviation sigma [cm] adds to the estimated
    kinetic energy at each sample of an estimated segment [(cm/s)^2]: T = (7/10) v^T M v with
    M = I + grad H grad H^T, so the velocity noise dv (variance s_v^2 per component, the two
    independent) adds (7/10) s_v^2 tr M = (7/10) s_v^2 (2 + |grad H|^2) on average (0.4-1
    (cm/s)^2 at the default 0.068 cm and 5 Hz); 0 when sigma is unknown."""
    if not (math.isfinite(sigma) and sigma > 0):
        return np.zeros(est["t"].size)
    gain = _velocity_noise_gain(round(float(est["dt"]), 12), est["method"], json.dumps(est["options"], sort_keys=True))
    g2 = est["gradH"][0] ** 2 + est["gradH"][1] ** 2
    return 0.7 * gain * sigma ** 2 * (2.0 + g2)


def _noise_response(seg: Segment, est: dict, sigma: float, k: int, rng) -> np.ndarray:
    """(k, n): the energy error at each sample caused by k realisations of white position noise
    of standard deviation sigma [cm], to first order: p . dv + dE/dq . dq_smoothed (dv, dq the
    estimator applied to the noise: it is linear)."""
    n = seg.t.size
    nx = rng.normal(0.0, sigma, (n, k))
    ny = rng.normal(0.0, sigma, (n, k))
    dvx, dsx = differentiate(nx, est["dt"], est["method"], **est["options"])
    dvy, dsy = differentiate(ny, est["dt"], est["method"], **est["options"])
    out = (est["px"][:, None] * dvx + est["py"][:, None] * dvy + est["dEdq"][0][:, None] * dsx
           + est["dEdq"][1][:, None] * dsy)
    return out.T


def window_energy(t, E, T, tc, half_width: float, trim: float = TRIM):
    """Energy at times tc by a local linear regression of E on the dissipation coordinate
    D(t) = integral of 2T dt over |t - tc| <= half_width (exact for viscous damping
    dE/dt = -2 c T, and for any slow damping law to first order). Samples within trim [s] of
    the segment's ends (where the estimators are least accurate) are left out while at least 10
    others remain. Returns (E_fit, slope, rows) with slope = dE/dD (-c for viscous damping) and
    rows[i] = (indices, weights) such that E_fit[i] = weights . E[indices]."""
    D = _dissipation(t, T)
    out = np.empty(len(tc))
    slope = np.empty(len(tc))
    rows = []
    inner = (t - t[0] >= trim) & (t[-1] - t >= trim)
    for i, c in enumerate(tc):
        near = np.abs(t - c) <= half_width
        sel = np.nonzero(near & inner)[0]
        if sel.size < 10:
            sel = np.nonzero(near)[0]
        if sel.size < 3:
            sel = np.argsort(np.abs(t - c))[:3]
        dc = np.interp(c, t, D)
        d = D[sel] - dc
        if np.ptp(D[sel]) <= 0:
            w = np.full(sel.size, 1.0 / sel.size)
            slope[i] = 0.0
        else:
            # the least-squares line E = a + b d: (a, b) = pinv([1, d]) E, the pseudo-inverse's rows
            # in closed form, about the points' mean dm (the two columns 1 and d - dm orthogonal)
            dm = d.mean()
            u = d - dm
            suu = u @ u
            w = 1.0 / sel.size - dm * u / suu
            slope[i] = (u / suu) @ E[sel]
        out[i] = w @ E[sel]
        rows.append((sel, w))
    return out, slope, rows


def noise_estimate(segments) -> float:
    """Position noise [cm] from the data: the residual of a Savitzky-Golay smoothing (window 11,
    order 3) over the interior samples, divided by sqrt(1 - h0) (h0 its central weight: white
    noise under a projection filter leaves a residual of variance sigma^2 (1 - h0))."""
    w, o = 11, 3
    S, _ = savgol_matrices(w, o)
    h0 = S[w // 2, w // 2]
    res = []
    for s in segments:
        if s.t.size < 2 * w:
            continue
        for a in (s.x, s.y):
            r = a[w // 2:-(w // 2)] - np.lib.stride_tricks.sliding_window_view(a, w) @ S[w // 2]
            res.append(r)
    if not res:
        return math.nan
    r = np.concatenate(res)
    return float(np.sqrt(np.mean(r * r) / (1 - h0)))


# --------------------------------------------------------------------------------------------
# Crossings of U1 and their fate
# --------------------------------------------------------------------------------------------

def _in_interval(r):
    """Of roots r (complex), those real (|imaginary part| < 1e-9) and in [0, 1] (to 1e-12)."""
    return (np.abs(r.imag) < 1e-9) & (r.real >= -1e-12) & (r.real <= 1 + 1e-12)


def _windows(t, i):
    """The first index of the 4 samples around each interval i (i-1 .. i+2, shifted at the ends)."""
    return np.minimum(np.maximum(i - 1, 0), t.size - 4)


def _cubic_weights(t4, tq):
    """Lagrange weights of the cubics through the 4 sample times of each row of t4 (m, 4),
    evaluated at tq (m): (m, 4)."""
    w = np.ones(t4.shape)
    for j in range(4):
        for m in range(4):
            if m != j:
                w[:, j] *= (tq - t4[:, m]) / (t4[:, j] - t4[:, m])
    return w


def _cubic_roots(t, g, level: float = 0.0):
    """Times where the sampled g crosses level: one per sign change of g - level between
    consecutive samples, the root inside that interval of the cubic through the 4 nearest samples
    (i-1 .. i+2, shifted at the ends; the middle root if there are three, linear interpolation if
    the cubic has none there). Returns (times, index of the sample before). All intervals at
    once: each cubic's coefficients in u = (t - t_i)/(t_{i+1} - t_i) by a 4x4 solve, its roots
    as the eigenvalues of its companion matrix (numpy's roots, batched)."""
    h = g - level
    s = np.sign(h)
    idx = np.nonzero((s[:-1] != 0) & (s[:-1] != s[1:]))[0]
    n = t.size
    a, b = t[idx], t[idx + 1]
    lin = a + (b - a) * h[idx] / (h[idx] - h[idx + 1])
    if n < 4 or idx.size == 0:
        return lin, idx
    w = _windows(t, idx)[:, None] + np.arange(4)
    u = (t[w] - a[:, None]) / (b - a)[:, None]
    c = np.linalg.solve(u[:, :, None] ** np.arange(3, -1, -1), h[w][:, :, None])[:, :, 0]   # exact through 4 points
    out = lin.copy()
    cubic = np.abs(c[:, 0]) > 0
    comp = np.zeros((idx.size, 3, 3))
    comp[:, 1, 0] = comp[:, 2, 1] = 1
    comp[:, 0, :] = -c[:, 1:] / np.where(cubic, c[:, 0], 1)[:, None]
    r = np.linalg.eigvals(comp)
    ok = _in_interval(r)
    rr = np.sort(np.where(ok, r.real, np.inf), axis=1)
    nr = ok.sum(axis=1)
    pick = rr[np.arange(idx.size), nr // 2]
    use = cubic & (nr > 0)
    out[use] = (a + (b - a) * pick)[use]
    for j in np.nonzero(~cubic)[0]:            # a degenerate cubic (a parabola or a line)
        r = np.roots(c[j])
        r = np.sort(r[_in_interval(r)].real)
        out[j] = a[j] + (b[j] - a[j]) * r[r.size // 2] if r.size else lin[j]
    return out, idx


def _at(t, arr, tq):
    """Cubic (4-point Lagrange) interpolation of the sampled arr at the times tq (linear with fewer
    than 4 samples, as _cubic_roots)."""
    tq = np.asarray(tq, dtype=float)
    if t.size < 4:       # (the windows would start before the first sample)
        return np.interp(tq, t, arr)
    i = np.clip(np.searchsorted(t, tq) - 1, 0, t.size - 2)
    w = _windows(t, i)[:, None] + np.arange(4)
    return np.einsum("ij,ij->i", _cubic_weights(t[w], tq), arr[w])


def _image(est: dict, k: int) -> dict:
    """The estimated segment mapped by IMAGES[k] (positions and velocities; the rest as is)."""
    if k == 0:
        return est
    (a, b), (c, d) = IMAGES[k][1]
    out = dict(est)
    out["x"], out["y"] = a * est["x"] + b * est["y"], c * est["x"] + d * est["y"]
    out["vx"], out["vy"] = a * est["vx"] + b * est["vy"], c * est["vx"] + d * est["vy"]
    return out


def find_crossings(est: dict, model: Model, x_gate: float, image: int = 0):
    """U1 crossings (theta = pi/4, x > 0) of one estimated segment: roots of y - x of the smoothed
    positions on the cubic through the 4 samples around each sign change, with positions and
    velocities interpolated there by the same cubics; and the gate passages (x falls below
    x_gate with y > 0). With image k, of the segment mapped by IMAGES[k] (another quadrant's
    diagonal, or the other direction). Returns (crossings: dict of arrays t, x, y, vx, vy, px, py,
    r, p_r, p_theta, branch, image; gate times)."""
    est = _image(est, image)
    t = est["t"]
    g = est["y"] - est["x"]
    tc, _ = _cubic_roots(t, g)
    xs, ys = _at(t, est["x"], tc), _at(t, est["y"], tc)
    keep = (xs + ys) > 0
    tc, xs, ys = tc[keep], xs[keep], ys[keep]
    q = 0.5 * (xs + ys)                       # on the ray x = y (to the cubic's accuracy)
    vx, vy = _at(t, est["vx"], tc), _at(t, est["vy"], tc)
    px, py, _, _ = state_energy(q, q, vx, vy, model) if tc.size else (np.zeros(0),) * 4
    r = np.sqrt(2.0) * q
    cr = {"t": tc, "x": q, "y": q.copy(), "vx": vx, "vy": vy, "px": px, "py": py, "r": r,
          "p_r": (q * px + q * py) / np.where(r > 0, r, 1), "p_theta": q * py - q * px}
    cr["branch"] = np.sign(cr["p_theta"]).astype(int)
    cr["image"] = np.full(tc.size, image, int)
    tg, _ = _cubic_roots(t, est["x"], x_gate)
    if tg.size:
        ok = (_at(t, est["vx"], tg) < 0) & (_at(t, est["y"], tg) > 0)
        tg = tg[ok]
    return cr, tg


def classify(cr: dict, tg: np.ndarray, t_first: float, t_last: float, edge: float = EDGE,
             guard: float = 0.0) -> np.ndarray:
    """Outcome of every crossing (only U1^- ones are meaningful): 1 the ball passes the gate
    before its next U1 crossing (transition), 0 it crosses U1 again first, -1 censored (neither
    before the segment ends, or within guard of the end), -2 within edge of a segment end."""
    tc = cr["t"]
    out = np.full(tc.size, OUTCOME_CENSORED, int)
    for i, c in enumerate(tc):
        if c - t_first < edge or t_last - c < edge:
            out[i] = OUTCOME_EDGE
            continue
        if t_last - c < guard:
            continue
        tn = tc[i + 1] if i + 1 < tc.size else math.inf
        after = tg[tg > c]
        t_g = after[0] if after.size else math.inf
        if t_g < tn:
            out[i] = OUTCOME_TRANSITION
        elif tn < math.inf:
            out[i] = OUTCOME_RETURN
    return out


# --------------------------------------------------------------------------------------------
# Theory
# --------------------------------------------------------------------------------------------

@dataclasses.dataclass
class Theory:
    path: str
    E_e: float
    growth_rate: float
    dE: np.ndarray
    p_trans: np.ndarray
    cuts: list                        # [(dE, r, p_r)] sorted by dE
    model: Model
    result: object = None             # tubes.load of the file (for the plots)
    angle: float = 45.0               # [deg] the section's ray (45: U1)

    def p(self, de) -> np.ndarray:
        """A_tube/A_E interpolated linearly in dE (p = 0 at dE <= 0; NaN above the last dE)."""
        de = np.asarray(de, float)
        out = np.interp(de, np.concatenate([[0.0], self.dE]), np.concatenate([[0.0], self.p_trans]))
        out = np.where(de <= 0, 0.0, out)
        return np.where(de > self.dE[-1], np.nan, out)

    def cut_for(self, de: float, rule: str = "at-or-above"):
        """The tube cut for a crossing at dE: the one of smallest dE >= de ('at-or-above'; the
        caller passes the bin's upper edge for the paper's 'bin-top'), or the nearest in dE
        ('nearest'); None if there is none."""
        if not self.cuts:
            return None
        ds = np.array([c[0] for c in self.cuts])
        if rule == "nearest":
            return self.cuts[int(np.argmin(np.abs(ds - de)))]
        j = np.nonzero(ds >= de - 1e-9)[0]
        return self.cuts[int(j[0])] if j.size else None


def load_theory(path: str, diagonal: int = 1) -> Theory:
    """Read /section, /transition and /tubes/stable_* of a tubes RESULT.h5 computed on the diagonal
    of quadrant 1 or 3 (diagonal = 1: U1 and its exact images, --theory) or of quadrant 2 or 4
    (diagonal = 2: --theory-q24); another section is refused."""
    import h5py
    from . import load
    if not pathlib.Path(path).exists():
        raise ExperimentError(f"{path}: no such theory file")
    try:
        res = load(path)
    except OSError as exc:
        raise ExperimentError(f"{path}: not a readable HDF5 file ({exc})") from exc
    for grp, what in (("section", "scenes tubes/transition"), ("transition", "scene transition")):
        if grp not in res:
            raise ExperimentError(f"{path}: no group /{grp} (run tubes with the {what})")
    tr = res.transition
    de = np.asarray(tr.dE, float)
    p = np.asarray(tr.p_trans, float)
    ok = np.isfinite(p)
    if not ok.any():
        raise ExperimentError(f"{path}: /transition/p_trans has no finite value")
    order = np.argsort(de[ok])
    cuts = []
    if "tubes" in res:
        for k in sorted(res.tubes.keys()):
            if k.startswith("stable_"):
                c = getattr(res.tubes, k)
                cuts.append((float(c.attrs["dE"]), np.asarray(c.r, float), np.asarray(c.p_r, float)))
    cuts.sort(key=lambda c: c[0])
    model = Model.of(res) if "model" in res else Model()
    if model.system != "rolling_ball":
        raise ExperimentError(f"{path}: the theory was computed for system {model.system!r}; the experiment "
                         "analysis is for the rolling ball (rolling_ball)")
    model = model.replace(damping_ratio=0.0)
    sec = res.section.attrs
    angle = math.degrees(float(sec.get("angle", math.pi / 4)))
    want = (45.0, 225.0) if diagonal == 1 else (135.0, 315.0)
    if not any(abs((angle - w + 180.0) % 360.0 - 180.0) < 1e-6 for w in want):
        raise ExperimentError(
            f"{path}: the theory's section is the ray at {angle:g} deg; "
            + ("--theory needs U1 (&section angle = 45) or quadrant 3's diagonal (225)" if diagonal == 1 else
               "--theory-q24 needs the diagonal of quadrant 2 (&section angle = 135, &orbits saddle = 'S23') or 4 "
               "(315, 'S14')"))
    return Theory(path, float(sec["E_e"]), float(sec["growth_rate"]), de[ok][order], p[ok][order],
                  cuts, model, res, angle)


def inside_polygon(px, py, vx, vy) -> np.ndarray:
    """Even-odd rule: which points (px, py) lie inside the closed polygon (vx, vy)."""
    px = np.atleast_1d(np.asarray(px, float))[:, None]
    py = np.atleast_1d(np.asarray(py, float))[:, None]
    x1, y1 = np.asarray(vx, float)[None, :], np.asarray(vy, float)[None, :]
    x2, y2 = np.roll(x1, -1, axis=1), np.roll(y1, -1, axis=1)
    cond = (y1 > py) != (y2 > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
    return (np.sum(cond & (px < xint), axis=1) % 2) == 1


# --------------------------------------------------------------------------------------------
# Statistics
# --------------------------------------------------------------------------------------------

def wilson(k, n, z: float):
    """Wilson score interval (lo, hi) for k successes in n (arrays; n may be non-integer, an
    effective sample size). NaN where n = 0."""
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = k / n
        den = 1 + z * z / n
        mid = (p + z * z / (2 * n)) / den
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return np.where(n > 0, mid - half, np.nan), np.where(n > 0, mid + half, np.nan)


def fit_slope(x, k, n, deff=1.0, iterations: int = 50):
    """Weighted least squares of the fraction k/n against x through the origin, with the
    binomial weights n_eff / (p (1 - p)) at p = slope x of the fit itself (iterated;
    n_eff = n / deff; p is floored at half a count, 0.5 / n_eff). Returns (slope, slope_err)."""
    x = np.asarray(x, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    ok = (n > 0) & (x > 0)
    if not ok.any():
        return math.nan, math.nan
    x, f, ne = x[ok], k[ok] / n[ok], n[ok] / np.broadcast_to(np.asarray(deff, float), n.shape)[ok]

    def weights(s):
        p = np.clip(s * x, 0.5 / ne, 1 - 0.5 / ne)
        return ne / (p * (1 - p))
    s = float(np.sum(ne * f * x) / np.sum(ne * x * x))
    for _ in range(iterations):
        w = weights(s)
        s_new = float(np.sum(w * f * x) / np.sum(w * x * x))
        done = abs(s_new - s) <= 1e-12 * max(abs(s), 1e-300)
        s = s_new
        if done:
            break
    w = weights(s)
    return s, float(1 / np.sqrt(np.sum(w * x * x)))


def fit_line(x, f, w):
    """Weighted straight line f = a + b x; returns (a, b, cov), or NaNs when fewer than two
    distinct x carry weight (one bin: a line through it is not determined)."""
    x, f, w = (np.asarray(v, float) for v in (x, f, w))
    ok = np.isfinite(x) & np.isfinite(f) & np.isfinite(w) & (w > 0)
    if np.unique(x[ok]).size < 2:
        return math.nan, math.nan, np.full((2, 2), math.nan)
    A = np.column_stack([np.ones_like(x[ok]), x[ok]])
    Aw = A * w[ok][:, None]
    try:
        cov = np.linalg.inv(A.T @ Aw)
    except np.linalg.LinAlgError:
        return math.nan, math.nan, np.full((2, 2), math.nan)
    a, b = cov @ (Aw.T @ f[ok])
    return float(a), float(b), cov


# --------------------------------------------------------------------------------------------
# The analysis
# --------------------------------------------------------------------------------------------

@dataclasses.dataclass
class Options:
    estimator: str = "spectral"
    estimator_options: dict = dataclasses.field(default_factory=dict)
    energy: str = "window"               # 'window' (regression) or 'instant'
    energy_window: float = ENERGY_WINDOW
    t_skip: float = T_SKIP
    gate: float = GATE
    plate: float = PLATE
    rate: float = 0.0                    # [Hz]; 0: from the file or the median time step
    noise: float = 0.0                   # [cm]; 0: estimated from the data
    bins: tuple = tuple(np.arange(-40.0, 400.0 + 1e-9, 40.0))
    confidence: float = 0.95
    fit_max: float = 160.0               # [(cm/s)^2] bins inside (0, fit_max] enter the slope fit
    edge: float = EDGE
    guard: float = 0.0
    resamples: int = 16                  # noise realisations for dE_err
    bootstrap: int = 400                 # track bootstrap replicates
    cut_rule: str = "at-or-above"
    compare: bool = True                 # also run the other estimator (dE_other)
    min_duration: float = MIN_DURATION
    jump_tol: float = 0.0                # [cm]; 0: max(1 cm, 12 noise)
    seed: int = 20180214
    max_impossible: float = 0.005        # refuse when more samples than this fraction lie too high
    decay_drift: bool = False            # the law's decay fits also take beta t (_decay_fits)
    fold: str = "none"                   # 'none' (U1^- only), 'exact' (Q1, Q3, both ways), 'all'


def _z(conf: float) -> float:
    from statistics import NormalDist
    return float(NormalDist().inv_cdf(0.5 + conf / 2))


def _gate_geometry(model: Model):
    eq = equilibria(model)
    if "S12" not in eq["name"]:
        raise ExperimentError("the model has no saddle S12")
    j = eq["name"].index("S12")
    return float(eq["x"][j]), float(eq["y"][j]), float(eq["energy"][j])


def _slow_frequency(model: Model) -> float:
    """omega_1 = sqrt((5/7) g kappa_min) at the well W1 (docs/theory.md), for zeta = c/(2 omega_1)."""
    eq = equilibria(model)
    j = eq["name"].index("W1") if "W1" in eq["name"] else 0
    _, hs = surface_derivatives([eq["x"][j]], [eq["y"][j]], model)
    kmin = np.linalg.eigvalsh(hs[:, :, 0]).min()
    return float(np.sqrt(5.0 / 7.0 * model.g * kmin))


def _analyse_segments(segs, opt: Options, method: str, model: Model, x_gate: float, E_e: float,
                      sigma: float, rng, rep: ValidationReport | None, decay: list | None = None,
                      energies: list | None = None):
    """Crossings of all segments with one estimator. The energetic check (heights above the
    energy available) drops samples and splits segments (reported in rep). decay, if given,
    receives per segment (track, XX, XE, EE, n, samples): the within-segment sums of the energy's
    decay regressions (_decay_fits) over its n samples more than DECAY_TRIM from its ends, XX (3, 3)
    and XE (3,) the products of the centred regressors X = (D, S, t) (D = the integral of 2 T dt,
    S = the path length of the centre, the integral of |v3| dt, both from the segment's start)
    with themselves and with the centred energy, EE = the sum of its squares; samples = (time since
    the segment's start, D, S, E) at those samples (for plot_dissipation)."""
    out = []
    queue = list(segs)
    final = []
    while queue:
        s = queue.pop(0)
        est = estimate_segment(s, method, opt.estimator_options if method == opt.estimator
                               else DEFAULT_OPTIONS[method], model)
        if rep is not None:
            bad, V, cap = _impossible_heights(s, est, model, sigma)
            if bad.any():
                for a, b in _runs(bad):
                    j = a + int(np.argmax(V[a:b] - cap[a:b]))
                    rep.add(s.track, "impossible_height", "warning", float(s.t[a]), float(s.t[b - 1]),
                            int(b - a), f"track {s.track}: {b - a} sample(s) at t = {s.t[a]:.6g}.."
                            f"{s.t[b - 1]:.6g} s lie higher than the energy of the track allows "
                            f"(g H up to {V[j]:.0f}, energy with tolerance {cap[j]:.0f} (cm/s)^2): dropped")
                need = max(min_samples_for(method, opt.estimator_options),
                           int(math.ceil(opt.min_duration * opt.rate)))
                for a, b in _runs(~bad):
                    sub = Segment(s.track, s.index[a:b], s.t[a:b], s.x[a:b], s.y[a:b])
                    if b - a < need:
                        rep.add(s.track, "short", "warning", float(sub.t[0]), float(sub.t[-1]),
                                int(b - a), f"track {s.track}: segment t = {sub.t[0]:.6g}.."
                                f"{sub.t[-1]:.6g} s has {b - a} samples, fewer than the {need} needed: "
                                f"dropped")
                        continue
                    queue.append(sub)
                continue
        if energies is not None:
            bal = _segment_balance(s.t, est["T"], est["E"])
            energies.append(bal)
            if rep is not None and abs(bal - 1) > SEGMENT_BALANCE_TOL:
                rep.add(s.track, "energy_balance", "warning", float(s.t[0]), float(s.t[-1]), int(s.t.size),
                        f"track {s.track}: segment t = {s.t[0]:.6g}..{s.t[-1]:.6g} s: g H trades with the kinetic "
                        f"energy at {bal:.3g} to 1 (the ball's: 1): these positions are not a ball rolling on the "
                        f"surface (a tracker glitch?): dropped")
                continue
        final.append(s)
        if decay is not None:
            b = noise_kinetic_energy(est, sigma)        # the noise's mean in T and E, taken out
            d = _dissipation(s.t, est["T"] - b)
            sp = _path_length(s.t, est["T"] - b)
            e = est["E"] - b
            ok = np.isfinite(d) & np.isfinite(sp) & np.isfinite(e)
            inner = ok & (s.t - s.t[0] >= DECAY_TRIM) & (s.t[-1] - s.t >= DECAY_TRIM)
            if inner.sum() >= 10:
                ok = inner
            if ok.sum() >= 3:
                ec = e[ok] - e[ok].mean()
                cols = [v[ok] - v[ok].mean() for v in (d, sp, s.t)]
                decay.append((s.track, np.array([[a @ b for b in cols] for a in cols]),
                              np.array([a @ ec for a in cols]), float(ec @ ec), int(ok.sum()),
                              (s.t[ok] - s.t[0], d[ok], sp[ok], e[ok], b[ok])))
        parts = []
        for k in FOLDS[opt.fold]:
            c, tg = find_crossings(est, model, x_gate, k)
            c["outcome"] = classify(c, tg, s.t[0], s.t[-1], opt.edge, opt.guard)
            parts.append(c)
        cr = {key: np.concatenate([c[key] for c in parts]) for key in parts[0]}
        # energies at the crossings (the ball's, in the surface's own frame)
        if opt.energy == "window":
            ew, slope, rows = window_energy(s.t, est["E"], est["T"], cr["t"], opt.energy_window)
        else:
            ew = state_energy(cr["x"], cr["y"], cr["vx"], cr["vy"], model)[2]
            slope = np.full(cr["t"].size, np.nan)
            rows = [(np.array([np.argmin(np.abs(s.t - c))]), np.ones(1)) for c in cr["t"]]
        cr["E"] = ew
        cr["dE"] = ew - E_e
        cr["E_instant"] = state_energy(cr["x"], cr["y"], cr["vx"], cr["vy"], model)[2]
        cr["damping_slope"] = -slope
        if opt.resamples > 0 and sigma > 0 and cr["t"].size:
            resp = _noise_response(s, est, sigma, opt.resamples, rng)
            de = np.array([resp[:, sel] @ w for sel, w in rows]).reshape(cr["t"].size, -1)
            cr["dE_noise"] = np.sqrt(np.mean(de * de, axis=1))
        else:
            cr["dE_noise"] = np.zeros(cr["t"].size)
        cr["track"] = np.full(cr["t"].size, s.track, int)
        cr["segment"] = np.full(cr["t"].size, len(final) - 1, int)
        out.append(cr)
    if not out:
        return None, final
    keys = out[0].keys()
    return {k: np.concatenate([c[k] for c in out]) for k in keys}, final


def _decay_forms(drift: bool) -> dict:
    """The regressions of the energy's decay (_decay_fits): name -> the indices of their regressors
    among X = (D, S, t) (_analyse_segments). The viscous one is the damping fit of old (with its
    drift term beta t); the law's forms take it too when drift is set."""
    return {"viscous": (0, 2), "viscous_law": (0, 2) if drift else (0,), "rolling": (1, 2) if drift else (1,),
            "combined": (0, 1, 2) if drift else (0, 1), "time": (2,), "path": (1,)}


def _decay_fits(decay: list, model: Model, opt: Options, rng) -> dict:
    """The energy's decay along the tracks against the model's two dissipation laws
    (docs/dissipation.md): viscous damping, dE/dt = -2 c T, and rolling resistance, dE/dt = -f |v3|
    (a loss of f per unit path length of the ball's centre, f = C_rr g). Least squares within
    every segment s (its own intercept a_s), pooled over the segments, of

        viscous   E = a_s - c D + beta t          D = the integral of 2 T dt
        rolling   E = a_s - f S                   S = the integral of |v3| dt, |v3| = sqrt(10 T / 7)
        combined  E = a_s - c D - f S

    with T and |v3| from the estimated velocities (_analyse_segments), the mean b that the position
    noise adds to T (noise_kinetic_energy) taken out of T and E, over the samples more than
    DECAY_TRIM = 0.2 s from the segment's ends (where the estimators err most: their errors there
    biased c and f by about a standard error). In the viscous fit (damping_rate, damping_ratio), as
    before, the term beta t takes up what remains of the noise: b in E and 2 b t in D, which biased c
    low by b / T (0.1-0.2 % at 0.05 cm noise). The law's forms leave it out unless opt.decay_drift:
    the path length grows almost linearly in time, so beta t takes up most of a rolling loss and
    multiplies the standard error of f by ~6 and, in the combined fit, those of c and f by 3-8
    (docs/experiment.md); without b taken out, 2 c b t made a spurious f of -4 se on 120 tracks
    at zeta = 0.025. Each coefficient's standard error is from a track bootstrap (opt.bootstrap
    replicates, at least 200; the same resampled sets for every fit); zeta = c / (2 omega_1)
    (docs/theory.md), C_rr = f / g. The
    residual rms of each law's fit [(cm/s)^2] over its samples (n - segments - regressors degrees
    of freedom) tells how well that law alone describes the decay; the viscous law's is of
    E = a_s - c D (+ beta t with opt.decay_drift), whose c is viscous_law_damping_rate.

    The loss against time and against path length: the pooled slopes of E on t alone and on S
    alone, energy_loss_rate = -dE/dt [(cm/s)^2/s] and energy_loss_per_length = -dE/ds [cm/s^2]:
    the mean loss per second and per cm of the centre's path (rolling resistance alone gives
    -dE/ds = f at any speed; viscous damping alone -dE/dt = 2 c <T>, and -dE/ds growing with the
    speed). Without opt.decay_drift the second is the rolling fit.

    The law (dissipation_law), from the combined fit: a coefficient is present when it lies more
    than LAW_PRESENT = 4 standard errors above 0, absent when its interval at opt.confidence
    (+- z se) contains 0. 'viscous': c present and f absent; 'rolling': f present and c absent;
    'both': both present; else 'undetermined': a coefficient between absent and present, or below 0
    beyond its interval (an energy gain, which neither law gives), or both absent (a ball without
    dissipation), or a single track (no bootstrap error)."""
    keys = ("damping_rate", "damping_rate_err", "damping_ratio", "damping_ratio_err", "rolling_drag",
            "rolling_drag_err", "rolling_resistance", "rolling_resistance_err", "combined_damping_rate",
            "combined_damping_rate_err", "combined_damping_ratio", "combined_damping_ratio_err",
            "combined_rolling_drag", "combined_rolling_drag_err", "combined_rolling_resistance",
            "combined_rolling_resistance_err", "residual_rms_viscous", "residual_rms_rolling",
            "residual_rms_combined", "viscous_law_damping_rate", "viscous_law_damping_rate_err", "energy_loss_rate",
            "energy_loss_rate_err", "energy_loss_per_length", "energy_loss_per_length_err")
    out = dict.fromkeys(keys, math.nan)
    out.update({"dissipation_law": "undetermined", "dissipation_law_threshold": LAW_PRESENT,
                "decay_drift": int(opt.decay_drift), "decay_trim": DECAY_TRIM})
    if not decay:
        return out
    forms = _decay_forms(opt.decay_drift)
    tr = np.array([d[0] for d in decay])
    tracks = np.unique(tr)
    mats = np.array([sum(d[1] for d in decay if d[0] == k) for k in tracks])   # (n_tracks, 3, 3)
    rhs = np.array([sum(d[2] for d in decay if d[0] == k) for k in tracks])    # (n_tracks, 3)
    ee = float(sum(d[3] for d in decay))
    n_free = sum(d[4] for d in decay) - len(decay)

    def solve(m, r, ix):
        """The coefficients of the regressors ix: dE/dD = -c, dE/dS = -f, beta."""
        try:
            return np.linalg.solve(m[np.ix_(ix, ix)], r[list(ix)])
        except np.linalg.LinAlgError:
            return np.full(len(ix), math.nan)
    m_all, r_all = mats.sum(0), rhs.sum(0)
    coef = {name: solve(m_all, r_all, ix) for name, ix in forms.items()}
    err = {name: np.full(len(ix), math.nan) for name, ix in forms.items()}
    if tracks.size > 1:
        w = rng.multinomial(tracks.size, np.full(tracks.size, 1.0 / tracks.size), size=max(opt.bootstrap, 200))
        boot = {name: [] for name in forms}
        for wi in w:
            mb, rb = np.tensordot(wi, mats, 1), wi @ rhs
            for name, ix in forms.items():
                boot[name].append(solve(mb, rb, ix))
        for name in forms:
            cb = np.array(boot[name])
            cb = cb[np.all(np.isfinite(cb), axis=1)]
            if cb.shape[0] > 1:
                err[name] = np.std(cb, axis=0)
    if not np.all(np.isfinite(coef["viscous"])):
        return out
    w1, g = _slow_frequency(model), model.g
    for law, name in (("viscous", "viscous_law"), ("rolling", "rolling"), ("combined", "combined")):
        dof = n_free - len(forms[name])
        rss = ee - float(coef[name] @ r_all[list(forms[name])])
        out[f"residual_rms_{law}"] = math.sqrt(max(rss, 0.0) / dof) if dof > 0 else math.nan
    c, c_err = -float(coef["viscous"][0]), float(err["viscous"][0])
    f, f_err = -float(coef["rolling"][0]), float(err["rolling"][0])
    cc, cc_err = -float(coef["combined"][0]), float(err["combined"][0])
    fc, fc_err = -float(coef["combined"][1]), float(err["combined"][1])
    out.update({
        "damping_rate": c, "damping_rate_err": c_err, "damping_ratio": c / (2 * w1),
        "damping_ratio_err": c_err / (2 * w1), "rolling_drag": f, "rolling_drag_err": f_err,
        "rolling_resistance": f / g, "rolling_resistance_err": f_err / g, "combined_damping_rate": cc,
        "combined_damping_rate_err": cc_err, "combined_damping_ratio": cc / (2 * w1),
        "combined_damping_ratio_err": cc_err / (2 * w1), "combined_rolling_drag": fc,
        "combined_rolling_drag_err": fc_err, "combined_rolling_resistance": fc / g,
        "combined_rolling_resistance_err": fc_err / g, "viscous_law_damping_rate": -float(coef["viscous_law"][0]),
        "viscous_law_damping_rate_err": float(err["viscous_law"][0]),
        "energy_loss_rate": -float(coef["time"][0]), "energy_loss_rate_err": float(err["time"][0]),
        "energy_loss_per_length": -float(coef["path"][0]), "energy_loss_per_length_err": float(err["path"][0]),
        "dissipation_law": _law(cc, cc_err, fc, fc_err, _z(opt.confidence))})
    return out


def _dissipation_summary(a: dict) -> list:
    """The summary's lines on the dissipation law, from an analysis' attrs (_decay_fits)."""
    z = _z(a["confidence"])
    drift = " + beta t" if a.get("decay_drift") else ""
    thr = a["dissipation_law_threshold"]

    def coef(v, e):
        return (f"{v / e:.1f} se: {_presence(v, e, z, thr)}" if e > 0 else "no se")
    law = a["dissipation_law"]
    what = {"viscous": "viscous damping (dE/dt = -2 c T)", "rolling": "rolling resistance (dE/dt = -f |v3|)",
            "both": "viscous damping and rolling resistance", "undetermined": "undetermined"}[law]
    c, ce = a["combined_damping_rate"], a["combined_damping_rate_err"]
    f, fe = a["combined_rolling_drag"], a["combined_rolling_drag_err"]
    if law == "undetermined" and ce > 0 and fe > 0 and _presence(c, ce, z, thr) == _presence(f, fe, z, thr) == "absent":
        what += " (neither law: no dissipation found)"
    cz, cze = a["combined_damping_ratio"], a["combined_damping_ratio_err"]
    cr, cre = a["combined_rolling_resistance"], a["combined_rolling_resistance_err"]
    r, re_ = a["rolling_resistance"], a["rolling_resistance_err"]
    conf = a["confidence"]
    return [
        f"dissipation from the energy's decay: {what}",
        f"  combined fit E = a - c D - f S{drift}: c = {_pm(c, ce, '.4g', unit=' 1/s')} (zeta {_pm(cz, cze, '.4g')}; "
        f"{coef(c, ce)}), f = {_pm(f, fe, '.4g', unit=' cm/s^2')} (C_rr {_pm(cr, cre, '.4g')}; {coef(f, fe)}) "
        f"[present: more than {thr:g} se above 0; absent: 0 inside the {conf:.0%} interval]",
        f"  rolling fit E = a - f S{drift} (S the centre's path): f = "
        f"{_pm(a['rolling_drag'], a['rolling_drag_err'], '.5g', unit=' cm/s^2')}, C_rr = f/g = "
        f"{_pm(r, re_, '.5g', z=z, conf=conf)}",
        f"  residual rms: viscous (E = a - c D{drift}) {a['residual_rms_viscous']:.2f}, rolling (E = a - f S{drift}) "
        f"{a['residual_rms_rolling']:.2f}, combined {a['residual_rms_combined']:.2f} (cm/s)^2",
        f"  energy loss against time -dE/dt = "
        f"{_pm(a['energy_loss_rate'], a['energy_loss_rate_err'], '.4g', unit=' (cm/s)^2/s')}, against path "
        f"length -dE/ds = {_pm(a['energy_loss_per_length'], a['energy_loss_per_length_err'], '.4g', unit=' cm/s^2')} "
        f"(mean slopes)"]


def _pm(v: float, e: float, fv: str, fe: str = ".2g", unit: str = "", z: float | None = None,
        conf: float = 0.95) -> str:
    """'v +- e unit' (and, with z, the interval at conf), never with a NaN: an error that is not a
    finite number (a single track: no bootstrap; the summary says why once) is said in words."""
    if not (math.isfinite(e) and e >= 0):
        return f"{v:{fv}}{unit} (no error)"
    out = f"{v:{fv}} +- {e:{fe}}{unit}"
    return out + (f" ({conf:.0%}: {v - z * e:{fv}} .. {v + z * e:{fv}})" if z is not None else "")


def _presence(v: float, e: float, z: float, threshold: float = LAW_PRESENT) -> str:
    """A coefficient v of standard error e: 'present' more than threshold e above 0, 'absent' within
    +- z e of 0, else 'unclear' ('unknown' without a finite e > 0)."""
    if not (math.isfinite(v) and math.isfinite(e) and e > 0):
        return "unknown"
    return "present" if v > threshold * e else "absent" if abs(v) <= z * e else "unclear"


def _law(c: float, c_err: float, f: float, f_err: float, z: float) -> str:
    """The dissipation law of the combined fit's coefficients c, f and their standard errors
    (_decay_fits): each present above LAW_PRESENT standard errors, absent within +- z of 0."""
    sc, sf = _presence(c, c_err, z), _presence(f, f_err, z)
    if sc == "present" and sf == "present":
        return "both"
    if sc == "present" and sf == "absent":
        return "viscous"
    if sf == "present" and sc == "absent":
        return "rolling"
    return "undetermined"


def _dissipation(t, T):
    """D(t) = integral of 2 T dt (trapezoidal) [(cm/s)^2 s]: dE/dt = -c dD/dt for viscous damping."""
    return np.concatenate([[0.0], np.cumsum((T[1:] + T[:-1]) * np.diff(t))])


def _path_length(t, T):
    """S(t) = integral of |v3| dt (trapezoidal) [cm], the path length of the ball's centre, with
    |v3| = sqrt(10 T / 7) (T = (7/10) |v3|^2): dE/dt = -f dS/dt for rolling resistance."""
    v = np.sqrt(np.maximum(10.0 / 7.0 * np.asarray(T, float), 0.0))
    return np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])


def _impossible_heights(s: Segment, est: dict, model: Model, sigma: float):
    """Samples whose potential energy g H (of the smoothed position) exceeds the energy the ball
    has there: E0(t) + b D(t), D the dissipation coordinate, b = -c the slope of a least-squares
    fit of E on D over the segment (residuals above 5 robust sigma dropped, repeated up to 5 times;
    clipped to a damping rate in [0, 2] 1/s), E0(t) the running median of E - b D over +-1 s
    (robust against the spikes and excursions shorter than 1 s that a glitch leaves in E).
    Tolerance: 5 sigma_E (robust noise of E from first differences) plus 3 g sigma (sigma the
    position noise; |grad H| < ~1.3 on the plate). Returns (flags, g H, energy + tolerance)."""
    t, E, T = s.t, est["E"], est["T"]
    n = E.size
    D = _dissipation(t, T)
    A = np.column_stack([np.ones(n), D])
    good = np.ones(n, bool)
    for _ in range(5):
        coef = np.linalg.lstsq(A[good], E[good], rcond=None)[0]
        res = E - A @ coef
        mad = 1.4826 * np.median(np.abs(res[good] - np.median(res[good])))
        new = np.abs(res) <= 5 * mad if mad > 0 else good
        if new.sum() < 3 or np.array_equal(new, good):
            break
        good = new
    b = float(np.clip(coef[1], -2.0, 0.0))
    F = E - b * D
    h = max(1, min(int(round(1.0 / est["dt"])), (n - 1) // 2))
    from scipy.ndimage import median_filter       # the running median (an odd window: exact)
    ref = median_filter(F, size=2 * h + 1, mode="nearest") + b * D
    d = np.diff(E)
    sig_e = 1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2) if d.size else 0.0
    V = potential_energy(est["x"], est["y"], model)
    cap = ref + 5 * sig_e + 3 * model.g * sigma
    return V > cap, V, cap


def _segment_balance(t, T, E) -> float:
    """The factor s in g H = a - s T - c D + beta t over one segment (least squares): along a track
    the potential energy g H falls by what the kinetic energy T gains, s = 1, up to the damping
    (c D, D the integral of 2 T dt) and the constant the noise adds to T (beta t), as in
    _decay_fits. Velocities off by a factor k (a time or length unit, a wrong frame period) give
    s = 1/k^2. NaN for fewer than 8 usable samples."""
    D = _dissipation(t, T)
    ok = np.isfinite(T) & np.isfinite(E) & np.isfinite(D)
    if ok.sum() < 8:
        return math.nan
    X = np.column_stack([T[ok], D[ok], t[ok]])
    X -= X.mean(0)
    V = E[ok] - T[ok]
    return float(-np.linalg.lstsq(X, V - V.mean(), rcond=None)[0][0])


@dataclasses.dataclass
class Analysis:
    options: Options
    report: ValidationReport
    crossings: dict            # U1^- crossings (per-crossing arrays)
    bins: dict                 # per-bin arrays
    attrs: dict                # scalars
    theory: Theory | None
    decay: list = dataclasses.field(default_factory=list)   # per segment (track, t - t_start, D, S, E)


def analyse(tracks: Tracks, theory: Theory | None = None, opt: Options | None = None,
            model: Model | None = None, theory_q24: Theory | None = None) -> Analysis:
    """The whole pipeline on a set of tracks (see the module docstring). theory_q24: the theory of
    the diagonals of quadrants 2 and 4, for their own table with --fold all."""
    opt = dataclasses.replace(opt) if opt is not None else Options()    # filled in below: a copy
    if opt.estimator not in ESTIMATORS:
        raise ExperimentError(f"unknown estimator {opt.estimator!r}; allowed: {', '.join(ESTIMATORS)}")
    if not opt.estimator_options:
        opt.estimator_options = dict(DEFAULT_OPTIONS[opt.estimator])
    model = model or (theory.model if theory is not None else Model())
    rng = np.random.default_rng(opt.seed)
    xs12, _, E_e = _gate_geometry(model)
    if theory is not None and abs(theory.E_e - E_e) > 1e-6 * abs(E_e):
        raise ExperimentError(f"{theory.path}: E_e = {theory.E_e} differs from the model's "
                              f"saddle energy {E_e} (different surface parameters?)")
    if theory is not None and tracks.attrs.get("surface_model"):
        made = json.loads(tracks.attrs["surface_model"])
        used = {"system": theory.model.system, **{k: theory.model.parameters.get(k) for k in SURFACE_PARAMS}}
        differ = [k for k in made if k == "system" and made[k] != used[k] or k != "system" and (
            used.get(k) is None or abs(made[k] - used[k]) > 1e-12 * max(abs(used[k]), 1.0))]
        if differ:
            raise ExperimentError(
                f"{theory.path}: the theory was computed for another model than the tracks "
                f"({tracks.source or 'the tracks'}): " + ", ".join(f"{k} = {used.get(k)} (theory) against {made[k]} (tracks)"
                                                 for k in differ)
                + "; compute the theory with the tracks' &model")
    if theory_q24 is not None:
        if opt.fold != "all":
            raise ExperimentError("--theory-q24 is for the crossings of quadrants 2 and 4: give --fold all")
        if abs(theory_q24.E_e - E_e) > 1e-6 * abs(E_e) or any(
                abs(theory_q24.model.parameters.get(k, 0.0) - model.parameters.get(k, 0.0)) >
                1e-12 * max(abs(model.parameters.get(k, 0.0)), 1.0) for k in SURFACE_PARAMS):
            raise ExperimentError(f"{theory_q24.path}: computed for another surface than the tracks' model "
                                  "(compute it with the same &model)")
    x_gate = xs12 - opt.gate
    # sampling rate
    rate = opt.rate or float(tracks.attrs.get("camera_rate", 0) or 0)
    if not rate > 0:
        d = np.diff(tracks.t)
        same = (np.diff(tracks.track) == 0) & np.isfinite(d)
        if d[same].size and np.count_nonzero(d[same] < 0) > d[same].size / 2:
            raise ExperimentError(f"{tracks.source}: time decreases within the tracks ({np.count_nonzero(d[same] < 0)} "
                                  f"of {d[same].size} steps): times must increase within a track (a reversed or "
                                  "negated time column?)")
        d = d[same & (d > 0)]
        if d.size == 0:
            raise ExperimentError(f"{tracks.source}: cannot infer the camera rate (give --rate)")
        rate = 1.0 / float(np.median(d))
    if not 1.0 <= rate <= 1.0e4:
        hint = ("times in milliseconds? give --time-unit ms" if rate < 1.0 else
                "times in seconds read as another unit? check --time-unit")
        raise ExperimentError(f"{tracks.source}: camera rate {rate:.6g} Hz is outside 1 Hz .. 10 kHz: "
                              f"{hint} (or give --rate)")
    opt.rate = rate
    # every position within 1 cm of the plate's centre (the top of the central hill, where no
    # ball stays): lengths in a larger unit read as cm
    reach = np.hypot(tracks.x, tracks.y)
    reach = reach[np.isfinite(reach)]
    if reach.size and float(reach.max()) < 1.0:
        raise ExperimentError(f"{tracks.source}: every position lies within {float(reach.max()):.3g} cm of the "
                              f"plate's centre, where no ball stays: positions in metres? give "
                              f"--length-unit m (or the right --length-unit / --pixel-size)")
    stated = tracks.attrs.get("noise"), tracks.attrs.get("pixel")
    nmin = max(min_samples_for(opt.estimator, opt.estimator_options),
               int(math.ceil(opt.min_duration * rate)))
    jt = opt.jump_tol
    if not jt > 0:
        jt = max(1.0, 12 * opt.noise) if opt.noise > 0 else 1.0
    segs, rep = validate(tracks, rate, opt.t_skip, opt.plate, nmin, jt)
    n_off = rep.samples_dropped().get("off_plate", 0)
    if n_off > 0.5 * tracks.t.size:
        raise ExperimentError(
            f"{tracks.source}: {n_off} of {tracks.t.size} samples ({100 * n_off / tracks.t.size:.0f} %) lie "
            f"off the plate (|x| or |y| > {opt.plate:g} cm): positions in another unit (give "
            f"--length-unit mm|m|px) or another frame: the plate's centre must be x = y = 0 (give --origin "
            f"X,Y, --rotate, --flip-y or a --calibration file of known points)?")
    if not segs:
        raise ExperimentError(f"{tracks.source}: no usable track segment\n{rep.summary()}\n" +
                              "\n".join(i.message for i in rep.issues[:20]))
    sigma_est = noise_estimate(segs)
    sigma = opt.noise if opt.noise > 0 else sigma_est
    decay, energies = [], []
    cr, segs = _analyse_segments(segs, opt, opt.estimator, model, x_gate, E_e, sigma, rng, rep, decay,
                                 energies)
    rep.n_segments = len(segs)
    rep.n_samples_used = int(sum(s.t.size for s in segs))
    n_high = rep.samples_dropped().get("impossible_height", 0)
    if n_high > opt.max_impossible * max(rep.n_samples, 1):
        raise ExperimentError(
            f"{tracks.source}: {n_high} of {rep.n_samples} samples ({100 * n_high / max(rep.n_samples, 1):.1f} %) lie "
            f"higher on the surface than their track's energy allows (correct data: none): the frame is probably "
            f"wrong (the image's y axis pointing down: --flip-y; a turned camera: --rotate or --calibration) or "
            f"the theory's surface is not the tracks'; --max-impossible {opt.max_impossible:g} is the limit")
    balance = float(np.nanmedian(energies)) if np.any(np.isfinite(energies)) else math.nan
    if math.isfinite(balance) and abs(balance - 1) > ENERGY_BALANCE_TOL:
        # velocities k times the right ones give balance = 1/k^2: said as a factor >= 1, the right way round
        if balance > 0:
            k = 1 / math.sqrt(balance)
            look = (f"the velocities look {k:.3g} times too large" if k >= 1 else
                    f"the velocities look {1 / k:.3g} times too small")
        else:
            look = "g H does not fall as T grows, which no scale of the velocities explains (the y axis upside down?)"
        raise ExperimentError(
            f"{tracks.source}: the kinetic and potential energies do not trade one for one along the tracks: "
            f"g H falls by {balance:.3g} times what T gains (1 on this surface; tolerance "
            f"{ENERGY_BALANCE_TOL:g}): {look} for the positions: check "
            f"--time-unit, --rate, --length-unit and --pixel-size, or the surface (--theory)")
    if cr is None:
        raise ExperimentError(f"{tracks.source}: no crossing of U1 in the analysed data\n{rep.summary()}")
    # the other estimator, for dE_other (same segments, no second energetic check)
    other = [m for m in ESTIMATORS if m != opt.estimator][0]
    if opt.compare:
        o2 = dataclasses.replace(opt, resamples=0)
        cr2, _ = _analyse_segments(segs, o2, other, model, x_gate, E_e, sigma, rng, None)
        cr["dE_other"] = _match(cr, cr2, "dE", MATCH_TOL)
        cr["outcome_other"] = _match(cr, cr2, "outcome", MATCH_TOL, fill=-9).astype(int)
    else:
        cr["dE_other"] = np.full(cr["t"].size, np.nan)
        cr["outcome_other"] = np.full(cr["t"].size, -9)
    diff = np.where(np.isfinite(cr["dE_other"]), cr["dE"] - cr["dE_other"], 0.0)
    cr["dE_err"] = np.hypot(cr["dE_noise"], diff)
    n_plus = int(np.sum(cr["branch"] < 0))
    n_all = int(cr["t"].size)
    minus = cr["branch"] > 0
    cm = {k: v[minus] for k, v in cr.items()}
    exact = np.array([IMAGES[k][3] for k in cm["image"]], bool)
    # truth (synthetic data)
    truth_attrs = {}
    if tracks.truth is not None:
        truth_attrs = _truth_check(tracks, cm, model, E_e, x_gate, opt, segs)
    # the transition fraction against the theory: U1^- and its exact images (Q1, Q3) only
    bins, attrs = _statistics({k: v[exact] for k, v in cm.items()}, opt, theory, rng)
    dec = cm["outcome"] >= 0
    attrs.update({"fold": opt.fold, "n_folded_crossings": int(dec.sum()),
                  "n_folded_transitions": int(np.sum(cm["outcome"] == OUTCOME_TRANSITION))})
    if not exact.all():
        # the other quadrants' wells are shallower: their own table, no theory (docs/experiment.md)
        other, oa = _statistics({k: v[~exact] for k, v in cm.items()}, opt, theory_q24, rng)
        bins.update({f"q24_{k}": v for k, v in other.items() if k not in ("dE_low", "dE_high", "in_fit")})
        attrs.update({f"q24_{k}": v for k, v in oa.items()})
    # the tube cuts
    attrs.update(_inside(cm, theory, opt, exact))
    # damping from the data: the regression slope -dE/dD = c
    ds = cm["damping_slope"]
    ds = ds[np.isfinite(ds)]
    c_hat = float(np.median(ds)) if ds.size else math.nan
    attrs.update({
        "n_u1_crossings": n_all, "n_u1_plus": n_plus, "n_u1_minus": int(minus.sum()),
        "n_censored": int(np.sum(cm["outcome"] == OUTCOME_CENSORED)),
        "n_edge": int(np.sum(cm["outcome"] == OUTCOME_EDGE)),
        "estimator": opt.estimator, "estimator_options": json.dumps(opt.estimator_options),
        "differentiator": differentiator_name(), "energy_method": opt.energy,
        "energy_window": opt.energy_window, "t_skip": opt.t_skip, "gate": opt.gate,
        "x_gate": x_gate, "x_S12": xs12, "E_e": E_e, "camera_rate": rate,
        "noise_estimate": sigma_est, "noise_used": sigma,
        "noise_stated": float(math.hypot(stated[0] or 0.0, (stated[1] or 0.0) / math.sqrt(12)))
        if stated[0] is not None or stated[1] is not None else math.nan,
        "confidence": opt.confidence, "fit_max": opt.fit_max, "edge": opt.edge, "guard": opt.guard,
        "resamples": opt.resamples, "cut_rule": opt.cut_rule,
        "outcome_agreement_estimators": float(np.mean(cm["outcome_other"][cm["outcome"] >= 0]
                                                      == cm["outcome"][cm["outcome"] >= 0]))
        if opt.compare and np.any(cm["outcome"] >= 0) else math.nan,
        "damping_rate_estimate": c_hat,
        "damping_ratio_estimate": c_hat / (2 * _slow_frequency(model)) if math.isfinite(c_hat) else math.nan,
    })
    attrs.update(_decay_fits(decay, model, opt, rng))
    nk = np.concatenate([d[5][4] for d in decay]) if decay else np.zeros(0)
    attrs["noise_kinetic_energy"] = float(np.mean(nk)) if nk.size else math.nan
    attrs["energy_balance"] = balance
    attrs.update(truth_attrs)
    return Analysis(opt, rep, cm, bins, attrs, theory, [(d[0], *d[5][:4]) for d in decay])


def _match(a: dict, b: dict, key: str, tol: float, fill=np.nan):
    """b[key] at the crossing of b nearest in time to each crossing of a (same branch, within tol)."""
    out = np.full(a["t"].size, fill, float)
    if b is None or b["t"].size == 0:
        return out
    for i, (t, br, tr, im) in enumerate(zip(a["t"], a["branch"], a["track"], a["image"])):
        j = np.nonzero((b["track"] == tr) & (b["branch"] == br) & (b["image"] == im))[0]
        if j.size:
            k = j[np.argmin(np.abs(b["t"][j] - t))]
            if abs(b["t"][k] - t) <= tol:
                out[i] = b[key][k]
    return out


def _statistics(cm: dict, opt: Options, theory: Theory | None, rng):
    edges = np.asarray(opt.bins, float)
    nb = edges.size - 1
    z = _z(opt.confidence)
    dec = cm["outcome"] >= 0
    dE = cm["dE"]
    b = np.digitize(dE, edges) - 1
    inb = dec & (b >= 0) & (b < nb)
    tracks = np.unique(cm["track"][inb])
    tix = {t: i for i, t in enumerate(tracks)}
    K = np.zeros((tracks.size, nb))
    N = np.zeros((tracks.size, nb))
    for i in np.nonzero(inb)[0]:
        N[tix[cm["track"][i]], b[i]] += 1
        K[tix[cm["track"][i]], b[i]] += cm["outcome"][i] == OUTCOME_TRANSITION
    n = N.sum(0)
    k = K.sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        f = k / n
    center = np.array([dE[inb & (b == j)].mean() if n[j] else 0.5 * (edges[j] + edges[j + 1])
                       for j in range(nb)])
    derr = np.array([np.sqrt(np.mean(cm["dE_err"][inb & (b == j)] ** 2)) if n[j] else np.nan
                     for j in range(nb)])
    censored = np.array([np.sum((cm["outcome"] == OUTCOME_CENSORED) & (b == j)) for j in range(nb)])
    # track bootstrap: design effect of the within-track correlation
    B = opt.bootstrap
    fb = np.full((B, nb), np.nan)
    if B > 0 and tracks.size > 1:
        W = rng.multinomial(tracks.size, np.full(tracks.size, 1.0 / tracks.size), size=B).astype(float)
        kb, nbb = W @ K, W @ N
        with np.errstate(invalid="ignore", divide="ignore"):
            fb = kb / nbb
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # bins without crossings: NaN
        sd_boot = np.nanstd(fb, axis=0) if B > 0 else np.full(nb, np.nan)
        var_bin = f * (1 - f) / n
        usable = (k > 0) & (k < n) & (n >= 10)
        deff = float(np.nansum((sd_boot ** 2)[usable]) / np.sum(var_bin[usable])) if usable.any() else 1.0
    deff = max(1.0, deff) if math.isfinite(deff) else 1.0
    lo, hi = (np.clip(v, 0.0, 1.0) for v in wilson(k / deff, n / deff, z))   # roundoff at k = 0, n
    wlo, whi = (np.clip(v, 0.0, 1.0) for v in wilson(k, n, z))
    ptheo = np.full(nb, np.nan)
    if theory is not None:
        pt = theory.p(dE)
        ptheo = np.array([np.mean(pt[inb & (b == j)]) if n[j] else np.nan for j in range(nb)])
    fitm = (edges[:-1] >= 0) & (edges[1:] <= opt.fit_max + 1e-9) & (n > 0)
    attrs = {"n_crossings": int(n.sum()), "n_transitions": int(k.sum()), "design_effect": deff,
             "n_tracks_with_crossings": int(tracks.size), "n_bins_fit": int(fitm.sum())}
    s = se = math.nan
    if fitm.any() and k[fitm].sum() == 0:
        # no transition: slope 0; the 95 % upper limit from Poisson (3 events): s sum(n dE) <= 3
        s = 0.0
        attrs["slope_upper_95"] = float(3.0 / np.sum(n[fitm] / deff * center[fitm]))
    elif fitm.any():
        s, se = fit_slope(center[fitm], k[fitm], n[fitm], deff)
        x = center[fitm]
        ne = n[fitm] / deff
        p = np.clip(s * x, 0.5 / ne, 1 - 0.5 / ne)
        w = ne / (p * (1 - p))
        chi2 = float(np.sum(w * (f[fitm] - s * x) ** 2))
        a, bb, cov = fit_line(x, f[fitm], w)
        if not math.isfinite(a):
            attrs["fit_note"] = (f"{int(fitm.sum())} bin(s) in the fit range (0, {opt.fit_max:g}]: the slope "
                                 "through the origin only; a free line needs two")
        attrs.update({"chi2": chi2, "dof": int(fitm.sum() - 1), "intercept_fit_intercept": a,
                      "intercept_fit_intercept_err": float(np.sqrt(cov[0, 0])),
                      "intercept_fit_slope": bb, "intercept_fit_slope_err": float(np.sqrt(cov[1, 1]))})
        if B > 0 and tracks.size > 1:
            sb = []
            for r in range(B):
                if np.sum(kb[r][fitm]) > 0:
                    sb.append(fit_slope(x, kb[r][fitm], nbb[r][fitm], 1.0, iterations=20)[0])
            attrs["slope_err_bootstrap"] = float(np.std(sb)) if len(sb) > 1 else math.nan
        if theory is not None and np.all(np.isfinite(ptheo[fitm])):
            attrs["slope_theory"] = float(np.sum(w * ptheo[fitm] * x) / np.sum(w * x * x))
    attrs["slope"], attrs["slope_err"] = s, se
    if theory is not None:
        attrs["growth_rate"] = theory.growth_rate
    bins = {"dE_low": edges[:-1], "dE_high": edges[1:], "dE_center": center, "dE_err": derr,
            "count": n.astype(np.int64), "transitions": k.astype(np.int64),
            "censored": censored.astype(np.int64), "fraction": f, "ci_low": lo, "ci_high": hi,
            "wilson_low": wlo, "wilson_high": whi, "fraction_std_bootstrap": sd_boot,
            "p_theory": ptheo, "in_fit": fitm.astype(np.int8)}
    return bins, attrs


def _inside(cm: dict, theory: Theory | None, opt: Options, exact: np.ndarray) -> dict:
    """Inside the tube cut of U1^- or not, for the decided crossings of U1^- and its exact images
    (exact); the others stay -1 (not evaluated)."""
    n = cm["t"].size
    cm["inside"] = np.full(n, -1, int)          # -1 not evaluated
    cm["cut_dE"] = np.full(n, np.nan)
    if theory is None or not theory.cuts:
        return {"inside_fraction": math.nan, "n_inside_evaluated": 0}
    edges = np.asarray(opt.bins, float)
    for i in range(n):
        if cm["outcome"][i] < 0 or not exact[i]:
            continue
        de = cm["dE"][i]
        if opt.cut_rule == "bin-top":          # the paper: the cut at the bin's upper edge
            j = np.searchsorted(edges, de, side="right")
            if j == 0 or j >= edges.size:
                continue
            de = edges[j]
        c = theory.cut_for(de, "nearest" if opt.cut_rule == "nearest" else "at-or-above")
        if c is None:
            continue
        cm["cut_dE"][i] = c[0]
        cm["inside"][i] = int(inside_polygon(cm["r"][i], cm["p_r"][i], c[1], c[2])[0])
    tr = (cm["outcome"] == OUTCOME_TRANSITION) & (cm["inside"] >= 0)
    nt = (cm["outcome"] == OUTCOME_RETURN) & (cm["inside"] >= 0)
    return {"inside_fraction": float(np.mean(cm["inside"][tr] == 1)) if tr.any() else math.nan,
            "n_inside_evaluated": int(tr.sum()),
            "n_transitions_inside": int(np.sum(cm["inside"][tr] == 1)),
            "nontransit_inside_fraction": float(np.mean(cm["inside"][nt] == 1)) if nt.any() else math.nan,
            "n_nontransit_evaluated": int(nt.sum())}


def truth_crossings(tracks: Tracks, segs, model: Model, x_gate: float, opt: Options) -> dict:
    """U1 crossings and outcomes of the noise-free samples of synthetic tracks (/tracks/truth:
    exact positions and velocities, the same segments, the same crossing code), with their true
    dE (the exact energy interpolated in time)."""
    from . import vector_field
    tr = tracks.truth
    # the conservative model's dq/dt (tubes.velocity, with the model made once, not per sample)
    cons = model.replace(damping_ratio=0.0) if "damping_ratio" in model.parameters else model
    nd = model.ndof
    E_true = tr.get("energy")
    if E_true is None:
        E_true = energy_of_states(tr["state"], model)
    _, _, E_e = _gate_geometry(model)
    out = []
    for j, s in enumerate(segs):
        st = tr["state"][s.index]
        v = vector_field(st.reshape(-1, 2 * nd), cons)[:, :nd]
        est = {"t": s.t, "x": st[:, 0], "y": st[:, 1], "vx": v[:, 0], "vy": v[:, 1]}
        for k in FOLDS[opt.fold]:
            c, tg = find_crossings(est, model, x_gate, k)
            c["outcome"] = classify(c, tg, s.t[0], s.t[-1], opt.edge, opt.guard)
            c["track"] = np.full(c["t"].size, s.track)
            c["segment"] = np.full(c["t"].size, j)
            c["dE"] = _at(s.t, E_true[s.index], c["t"]) - E_e
            out.append(c)
    return {k: np.concatenate([c[k] for c in out]) for k in out[0]}


def _truth_check(tracks: Tracks, cm: dict, model: Model, E_e: float, x_gate: float, opt: Options,
                 segs) -> dict:
    """Against /tracks/truth: each estimated U1^- crossing is matched to the true crossing of the
    same branch nearest in time (within MATCH_TOL); dE, r, p_r errors and outcome agreement."""
    tc = truth_crossings(tracks, segs, model, x_gate, opt)
    tol = MATCH_TOL
    cm["outcome_truth"] = _match(cm, tc, "outcome", tol, fill=-9).astype(int)
    cm["dE_truth"] = _match(cm, tc, "dE", tol)
    r_t = _match(cm, tc, "r", tol)
    pr_t = _match(cm, tc, "p_r", tol)
    tminus = {k: v[tc["branch"] > 0] for k, v in tc.items()}
    back = _match(tminus, cm, "t", tol)
    m = np.isfinite(cm["dE_truth"])
    err = cm["dE"][m] - cm["dE_truth"][m]
    dec = (cm["outcome"] >= 0) & (cm["outcome_truth"] >= 0)
    agree = cm["outcome"][dec] == cm["outcome_truth"][dec]
    with np.errstate(invalid="ignore", divide="ignore"):
        z = err / cm["dE_err"][m]
    return {"truth_dE_rms": float(np.sqrt(np.mean(err ** 2))) if err.size else math.nan,
            "truth_dE_bias": float(np.mean(err)) if err.size else math.nan,
            "truth_dE_z_rms": float(np.sqrt(np.nanmean(z ** 2))) if err.size else math.nan,
            "truth_r_rms": float(np.sqrt(np.mean((cm["r"][m] - r_t[m]) ** 2))) if err.size else math.nan,
            "truth_p_r_rms": float(np.sqrt(np.mean((cm["p_r"][m] - pr_t[m]) ** 2))) if err.size else math.nan,
            "truth_outcome_agreement": float(np.mean(agree)) if agree.size else math.nan,
            "truth_n_outcome_compared": int(agree.size),
            "truth_n_u1_minus": int(tminus["t"].size), "truth_matched": int(m.sum()),
            "truth_missed": int(np.sum(~np.isfinite(back))), "truth_spurious": int(np.sum(~m))}


# --------------------------------------------------------------------------------------------
# Output
# --------------------------------------------------------------------------------------------

def write_analysis(path: str, an: Analysis, argv=None, tracks_path: str = "", option: str | None = None) -> None:
    """Write /experiment (bins, attributes), /experiment/crossings, /experiment/validation into
    path by the writer rule of tubes._output (made in memory, written to PATH.tmp.<pid>, renamed;
    tubes._output.OutputError naming path or option on failure, nothing left)."""
    _output.emit(path, analysis_image(an, argv, tracks_path), option)


def analysis_image(an: Analysis, argv=None, tracks_path: str = "") -> bytes:
    """The bytes of the HDF5 file write_analysis writes."""
    import h5py
    str_dt = h5py.string_dtype()

    def fill(f):
        f.attrs["created"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        f.attrs["command_line"] = " ".join(argv) if argv else ""
        f.attrs["tracks_file"] = tracks_path
        f.attrs["theory_file"] = an.theory.path if an.theory else ""
        if an.theory is not None and an.theory.result is not None:
            f.attrs["theory_git_commit"] = str(an.theory.result.attrs.get("git_commit", ""))
        g = f.create_group("experiment")
        units = {"dE_low": "(cm/s)^2", "dE_high": "(cm/s)^2", "dE_center": "(cm/s)^2",
                 "dE_err": "(cm/s)^2", "q24_dE_center": "(cm/s)^2", "q24_dE_err": "(cm/s)^2"}
        for k, v in an.bins.items():
            d = g.create_dataset(k, data=np.asarray(v))
            d.attrs["units"] = units.get(k, "1")
        for k, v in an.attrs.items():
            g.attrs[k] = v
        c = g.create_group("crossings")
        cu = {"t": "s", "r": "cm", "p_r": "cm/s", "p_theta": "cm^2/s", "x": "cm", "y": "cm",
              "vx": "cm/s", "vy": "cm/s", "px": "cm/s", "py": "cm/s", "E": "(cm/s)^2",
              "dE": "(cm/s)^2", "dE_err": "(cm/s)^2", "dE_noise": "(cm/s)^2",
              "dE_other": "(cm/s)^2", "dE_truth": "(cm/s)^2", "E_instant": "(cm/s)^2",
              "cut_dE": "(cm/s)^2", "damping_slope": "1/s"}
        for k, v in an.crossings.items():
            d = c.create_dataset(k, data=np.asarray(v))
            d.attrs["units"] = cu.get(k, "1")
        v = g.create_group("validation")
        rep = an.report
        for k in ("n_tracks", "n_tracks_rejected", "n_samples", "n_samples_skipped",
                  "n_samples_used", "n_segments"):
            v.attrs[k] = getattr(rep, k)
        for k, n in rep.counts().items():
            v.attrs[f"count_{k}"] = n
        for k, n in rep.samples_dropped().items():
            v.attrs[f"samples_{k}"] = n
        iss = rep.issues
        v.create_dataset("track", data=np.array([i.track for i in iss], dtype=np.int64))
        v.create_dataset("t_start", data=np.array([i.t_start for i in iss], float))
        v.create_dataset("t_end", data=np.array([i.t_end for i in iss], float))
        v.create_dataset("n_samples", data=np.array([i.n_samples for i in iss], dtype=np.int64))
        v.create_dataset("kind", data=[i.kind for i in iss], dtype=str_dt)
        v.create_dataset("severity", data=[i.severity for i in iss], dtype=str_dt)
        v.create_dataset("message", data=[i.message for i in iss], dtype=str_dt)
    return _output.h5_image(fill)


def slope_text(a: dict, digits: int = 3) -> str | None:
    """The fitted transition slope of an analysis' attrs as text, never with a NaN: with its error,
    or why the fit is undefined (no transition in the fit range: slope 0 and its 95 % upper limit;
    no bin in the fit range: None)."""
    if "slope_upper_95" in a:
        return (f"no transition at 0 < dE <= {a['fit_max']:g}: the fit is undefined (slope 0, no error); "
                f"95 % upper limit {a['slope_upper_95'] * 1e3:.{digits}f}e-3 (s/cm)^2")
    s, se = a.get("slope", math.nan), a.get("slope_err", math.nan)
    if not math.isfinite(s):
        return None
    if not math.isfinite(se):
        return f"slope {s * 1e3:.{digits}f}e-3 (s/cm)^2 (its error undefined: the binomial weights are)"
    return f"slope ({s * 1e3:.{digits}f} +- {se * 1e3:.{digits}f})e-3 (s/cm)^2"


def plot_analysis(path: str, an: Analysis, section_range=(40.0, 140.0), option: str | None = None) -> None:
    """The paper's Fig. 4: (a) U1^- crossings with dE in section_range by outcome, with the tube
    cut at or above the range's upper end and the energy boundary there; (b) the transition
    fraction against dE with its intervals, the fit and the theory."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from .plots import energy_boundary
    cm, b, a = an.crossings, an.bins, an.attrs
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12.5, 5.0))
    lo, hi = section_range
    s = (cm["dE"] >= lo) & (cm["dE"] < hi) & np.array([IMAGES[k][3] for k in cm["image"]], bool)
    th = an.theory
    if th is not None:
        cut = th.cut_for(hi)
        if cut is not None:
            ax1.fill(cut[1], cut[2], color="c", alpha=0.45,
                     label=f"stable tube cut, dE = {cut[0]:g}")
            ax1.plot(np.append(cut[1], cut[1][0]), np.append(cut[2], cut[2][0]), "b", lw=1)
        if th.result is not None and "section" in th.result and "model" in th.result:
            br, bp = energy_boundary(th.result, hi)
            ax1.plot(br, bp, color="m", lw=1.2, label=f"energy boundary, dE = {hi:g}")
    for code, col, lab in ((OUTCOME_RETURN, "k", "no transition"), (OUTCOME_TRANSITION, "r", "transition"),
                           (OUTCOME_CENSORED, "0.6", "censored")):
        m = s & (cm["outcome"] == code)
        ax1.plot(cm["r"][m], cm["p_r"][m], "o", ms=3.5 if code else 2.5, color=col,
                 label=f"{lab} ({int(m.sum())})")
    ax1.set_xlabel("r [cm]")
    ax1.set_ylabel("p_r [cm/s]")
    ax1.set_title(f"U1^- crossings with dE in [{lo:g}, {hi:g}) (cm/s)^2")
    ax1.legend(fontsize=7, loc="upper right")
    ok = b["count"] > 0
    x = b["dE_center"][ok]
    f = b["fraction"][ok]
    yerr = np.clip(np.array([f - b["ci_low"][ok], b["ci_high"][ok] - f]), 0, None)   # roundoff at k = 0
    ax2.errorbar(x, f, yerr=yerr, xerr=b["dE_err"][ok], fmt="o", color="k", ms=4, capsize=2,
                 label=f"tracks ({int(a['confidence'] * 100)}% Wilson, design effect "
                       f"{a['design_effect']:.2f})")
    if th is not None:
        dd = np.linspace(0, th.dE[-1], 300)
        ax2.plot(dd, th.p(dd), "b-", label="A_tube / A_E (tubes)")
        ax2.plot(dd, th.growth_rate * dd, "b:", lw=0.8, label="(T_po / A0) dE")
    if math.isfinite(a.get("slope", math.nan)):
        dd = np.linspace(0, a["fit_max"], 50)
        ax2.plot(dd, a["slope"] * dd, "r--", label=f"fit: {slope_text(a, 2)}")
    ax2.axhline(0, color="0.5", lw=0.5)
    ax2.set_xlabel("dE [(cm/s)^2]")
    ax2.set_ylabel("transition fraction")
    ax2.set_title(f"{a['n_crossings']} crossings of U1^-, {a['n_transitions']} transitions")
    ax2.legend(fontsize=7, loc="upper left")
    ax2.grid(True, lw=0.3)
    fig.tight_layout()
    try:
        _output.save_figure(fig, path, option, dpi=130)
    finally:
        plt.close(fig)


def plot_dissipation(path: str, an: Analysis, max_segments: int = 300, option: str | None = None) -> None:
    """The energy lost since each segment's start against the time since that start, the path
    length S of the ball's centre and D = the integral of 2 T dt (one thin line per segment, at
    most max_segments of them, evenly chosen): a_s - E, a_s the segment's starting energy by the
    combined fit (E + c D + f S averaged over the segment). Rolling resistance puts the segments on
    one line against S (slope f, the rolling fit, drawn), viscous damping against D (slope c of
    the viscous law's fit, viscous_law_damping_rate, drawn); against time the slope is the mean loss
    rate (drawn)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    a = an.attrs
    fig, axes = plt.subplots(1, 3, figsize=(15.0, 4.6), sharey=True)
    c, f = a.get("combined_damping_rate", math.nan), a.get("combined_rolling_drag", math.nan)
    segs = an.decay
    if len(segs) > max_segments:
        segs = [segs[i] for i in np.linspace(0, len(segs) - 1, max_segments).round().astype(int)]
    top = [0.0, 0.0, 0.0]
    for _, t, D, S, E in segs:
        a_s = float(np.mean(E + (c if math.isfinite(c) else 0.0) * D + (f if math.isfinite(f) else 0.0) * S))
        for k, x in enumerate((t, S, D)):
            axes[k].plot(x, a_s - E, "-", color="0.3", lw=0.4, alpha=0.5)
            top[k] = max(top[k], float(np.max(x)))
    lines = ((a.get("energy_loss_rate", math.nan), "mean rate -dE/dt = {:.4g} (cm/s)^2/s"),
             (a.get("rolling_drag", math.nan), "rolling fit f = {:.4g} cm/s^2"),
             (a.get("viscous_law_damping_rate", math.nan), "viscous fit c = {:.4g} 1/s"))
    labels = ("time since the segment's start [s]", "path length of the centre S [cm]",
              "D = integral of 2 T dt [(cm/s)^2 s]")
    for ax, (slope, text), xl, x_top in zip(axes, lines, labels, top):
        if math.isfinite(slope):
            xx = np.linspace(0.0, x_top, 2)
            ax.plot(xx, slope * xx, "r--", lw=1.2, label=text.format(slope))
            ax.legend(fontsize=8, loc="upper left")
        ax.set_xlabel(xl)
        ax.grid(True, lw=0.3)
    axes[0].set_ylabel("energy lost since the segment's start [(cm/s)^2]")
    fig.suptitle(f"the energy's decay along {len(an.decay)} segments: law {a.get('dissipation_law', '?')}",
                 fontsize=10)
    fig.tight_layout()
    try:
        _output.save_figure(fig, path, option, dpi=120)
    finally:
        plt.close(fig)


# --------------------------------------------------------------------------------------------
# Synthetic tracks and tuning
# --------------------------------------------------------------------------------------------

def _grad(x, y, model):
    """grad H from tubes.vector_field at rest: dp/dt = -g grad H."""
    f = vector_field((x, y, 0.0, 0.0), model)
    return -f[2:] / model.g


def _release_point(E, phi, model):
    """The point on the outer zero-velocity curve g H = E along the direction phi."""
    from scipy.optimize import brentq

    def f(r):
        return energy((r * np.cos(phi), r * np.sin(phi), 0.0, 0.0), model) - E
    rr = np.linspace(2.0, 14.0, 61)
    r0 = rr[int(np.argmin([f(r) for r in rr]))]
    r = brentq(f, r0, 40.0, xtol=1e-12)
    return r * np.cos(phi), r * np.sin(phi)


def _microcanonical(E, model, rng, box=14.0):
    """A state uniform on the energy surface E: q with density sqrt(det M) = sqrt(1 + |grad H|^2)
    on {g H < E}, momentum uniform in the angle of the ellipse T = E - g H (docs/experiment.md)."""
    gmax = math.sqrt(1 + 2.0 ** 2)
    while True:
        x, y = rng.uniform(-box, box, 2)
        K = E - energy((x, y, 0.0, 0.0), model)
        if K <= 0:
            continue
        g = _grad(x, y, model)
        g2 = float(g @ g)
        if rng.uniform() * gmax > math.sqrt(1 + g2):
            continue
        phi = rng.uniform(0, 2 * np.pi)
        u = np.array([np.cos(phi), np.sin(phi)])
        gh = g / math.sqrt(g2) if g2 > 0 else np.zeros(2)
        mh = np.eye(2) + (math.sqrt(1 + g2) - 1) * np.outer(gh, gh)     # M^(1/2)
        p = math.sqrt(14 * K / 5) * (mh @ u)
        return np.array([x, y, p[0], p[1]])


def synthetic_tracks(n_tracks: int, duration: float = 10.0, rate: float = 50.0, noise: float = 0.05,
                     pixel: float = 0.16, damping_ratio: float = 0.0, ensemble: str = "rest",
                     dE_range=(1000.0, 2000.0), seed: int = 1, model: Model | None = None,
                     rolling_resistance: float = 0.0) -> Tracks:
    """Tracks integrated with tubes.integrate (DOP853, rtol 1e-10), sampled at rate [Hz], with
    Gaussian position noise [cm] and then quantised to pixel [cm]. The ball's dissipation: viscous
    damping of ratio damping_ratio and rolling resistance of coefficient rolling_resistance (the
    model's own are replaced; docs/dissipation.md). ensemble 'rest': released from rest on the
    outer zero-velocity curve at E_e + dE (dE uniform in dE_range), as in the experiment;
    'microcanonical': a state uniform on that energy surface. truth holds the exact states,
    energies and dE at the samples."""
    model = model or Model()
    model = model.replace(damping_ratio=damping_ratio, rolling_resistance=rolling_resistance)
    cons = model.replace(damping_ratio=0.0, rolling_resistance=0.0)
    _, _, E_e = _gate_geometry(cons)
    rng = np.random.default_rng(seed)
    tk, tt, xx, yy, st = [], [], [], [], []
    for k in range(n_tracks):
        de = rng.uniform(*dE_range)
        if ensemble == "rest":
            x0, y0 = _release_point(E_e + de, rng.uniform(0, 2 * np.pi), cons)
            z0 = np.array([x0, y0, 0.0, 0.0])
        elif ensemble == "microcanonical":
            z0 = _microcanonical(E_e + de, cons, rng)
        else:
            raise ValueError(f"unknown ensemble {ensemble!r}")
        r = integrate(z0, duration, dt_out=1.0 / rate, model=model, rtol=1e-10, atol=1e-10)
        n = r["t"].size
        tk.append(np.full(n, k))
        tt.append(r["t"])
        st.append(r["state"])
        x = r["state"][:, 0] + rng.normal(0, noise, n)
        y = r["state"][:, 1] + rng.normal(0, noise, n)
        if pixel > 0:
            x = pixel * np.round(x / pixel)
            y = pixel * np.round(y / pixel)
        xx.append(x)
        yy.append(y)
    state = np.concatenate(st)
    en = energy_of_states(state, cons)
    attrs = {"camera_rate": rate, "pixel": pixel, "noise": noise, "damping_ratio": damping_ratio,
             "rolling_resistance": rolling_resistance, "seed": seed, "n_tracks": n_tracks, "E_e": E_e}
    return Tracks(np.concatenate(tk).astype(np.int64), np.concatenate(tt), np.concatenate(xx),
                  np.concatenate(yy), attrs, {"state": state, "energy": en, "dE": en - E_e},
                  "synthetic")


def tune(tracks: Tracks, grid: dict | None = None, windows=(0.0, 0.5, 1.0, 2.0),
         model: Model | None = None) -> list:
    """Measure each estimator setting against the truth of synthetic tracks: the rms velocity
    error over the interior samples of the segments (more than 0.2 s from an end) and the rms and
    mean error of E at the U1^- crossings, instantaneous (window 0) or windowed. Returns rows
    (method, options, window, v_rms, dE_rms, dE_bias, n) sorted by dE_rms."""
    from . import velocity
    model = model or Model()
    grid = grid or {"spectral": [{"cutoff": c, "edge": e} for c in (4.0, 5.0, 6.0) for e in ("odd", "mirror")],
                    "savgol": [{"window": w, "order": o} for (w, o) in ((11, 3), (15, 4), (19, 4))]}
    xs12, _, E_e = _gate_geometry(model)
    rate = float(tracks.attrs.get("camera_rate", 50.0))
    segs, _ = validate(tracks, rate, T_SKIP, PLATE, 60, 1e9)
    tv = {}
    for s in segs:
        st = tracks.truth["state"][s.index]
        tv[id(s)] = velocity(st.reshape(-1, 2 * model.ndof), model)
    rows = []
    for method, opts in grid.items():
        for o in opts:
            verr, eerr = [], {w: [] for w in windows}
            for s in segs:
                est = estimate_segment(s, method, o, model)
                v = tv[id(s)]
                inner = (s.t - s.t[0] > 0.2) & (s.t[-1] - s.t > 0.2)
                verr.append(np.hypot(est["vx"] - v[:, 0], est["vy"] - v[:, 1])[inner])
                cr, _ = find_crossings(est, model, xs12 - GATE)
                m = (cr["branch"] > 0) & (cr["t"] - s.t[0] > EDGE) & (s.t[-1] - cr["t"] > EDGE)
                tc = cr["t"][m]
                etrue = np.interp(tc, s.t, tracks.truth["energy"][s.index])
                for w in windows:
                    if w == 0:
                        e = state_energy(cr["x"][m], cr["y"][m], cr["vx"][m], cr["vy"][m], model)[2]
                    else:
                        e, _, _ = window_energy(s.t, est["E"], est["T"], tc, w)
                    eerr[w].append(e - etrue)
            v = np.concatenate(verr)
            for w in windows:
                e = np.concatenate(eerr[w])
                rows.append((method, o, w, float(np.sqrt(np.mean(v * v))), float(np.sqrt(np.mean(e * e))),
                             float(np.mean(e)), int(e.size)))
    rows.sort(key=lambda r: r[4])
    return rows


# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------

MAX_BINS = 1000            # --bins: at most this many dE bins (the paper's figure has 11)
MAX_RESAMPLES = 1000       # --resamples: noise realisations (16 give dE_noise to ~18 %; 1000 to ~2 %)
MAX_BOOTSTRAP = 100000     # --bootstrap: track bootstrap replicates (400 by default)


def _parse_bins(s: str) -> tuple:
    try:
        if ":" in s:
            a, b, c = (_ascii_float(v) for v in s.split(":"))
            if not (math.isfinite(a) and math.isfinite(b) and c > 0 and b > a):
                raise ValueError
            n = math.ceil((b + 0.5 * c - a) / c)      # the edges np.arange would make
            if not n <= MAX_BINS + 1:
                raise argparse.ArgumentTypeError(
                    f"bins {s!r}: {n - 1:.3g} bins; at most {MAX_BINS} are allowed (a larger STEP)")
            e = np.arange(a, b + 0.5 * c, c)
        else:
            e = np.array([_ascii_float(v) for v in s.split(",")])
            if e.size > MAX_BINS + 1:
                raise argparse.ArgumentTypeError(f"bins: {e.size - 1} bins; at most {MAX_BINS} are allowed")
    except ValueError:
        raise argparse.ArgumentTypeError(f"bins {s!r}: give START:STOP:STEP (finite, STOP > START, STEP > 0) or "
                                         f"increasing edges e1,e2,... in (cm/s)^2") from None
    if e.size < 2 or np.any(np.diff(e) <= 0) or not np.all(np.isfinite(e)):
        raise argparse.ArgumentTypeError(f"bins {s!r}: need at least two increasing finite edges")
    return tuple(e)


def _count(limit: int):
    """An argparse type: an integer in 0 .. limit."""
    def parse(s: str) -> int:
        try:
            v = int(s) if _ASCII_INT.fullmatch(s.strip()) else None
        except ValueError:
            v = None
        if v is None or not 0 <= v <= limit:
            raise argparse.ArgumentTypeError(f"{s!r}: give an integer from 0 to {limit}")
        return v
    return parse


def _number(s: str) -> float:
    """An argparse type: a finite number written in ASCII."""
    try:
        v = _ascii_float(s)
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{s!r}: give a finite number ({ASCII_NUMBER})")
    return v


def _integer(s: str) -> int:
    """An argparse type: an integer written in ASCII digits."""
    if not _ASCII_INT.fullmatch(s.strip(" \t")):
        raise argparse.ArgumentTypeError(f"{s!r}: give an integer (ASCII digits 0-9, optional sign)")
    return int(s)


def _parse_pair(s: str) -> tuple:
    try:
        a, b = (_ascii_float(v) for v in s.split(","))
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"{s!r}: give X,Y (two finite numbers)") from None
    return a, b


def _parse_columns(s: str) -> dict:
    out = {}
    for item in s.split(","):
        k, sep, v = item.partition("=")
        k, v = k.strip(), v.strip()
        if not sep or k not in ("track", "t", "x", "y") or not v:
            raise argparse.ArgumentTypeError(f"columns {s!r}: give track=NAME,t=NAME,x=NAME,y=NAME "
                                             f"(any subset; {item!r} is not of that form)")
        out[k] = v
    return out


def _parse_range(s: str) -> tuple:
    try:
        a, b = (_ascii_float(v) for v in s.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{s!r}: give LOW,HIGH") from None
    if not (math.isfinite(a) and math.isfinite(b) and b > a):
        raise argparse.ArgumentTypeError(f"{s!r}: need LOW < HIGH")
    return a, b


def _positive(s: str) -> float:
    try:
        v = _ascii_float(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{s!r} is not a number ({ASCII_NUMBER})") from None
    if not v >= 0 or not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{s!r} must be >= 0")
    return v


def main(argv=None) -> int:
    """The command line, python -m tubes.experiment TRACKS [options] (docs/experiment.md): argv
    without the program's name (default sys.argv[1:]); returns the exit status (docs/experiment.md:
    0 ok, 1 bad input, an output error's code); a bad option exits with argparse's 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    orig = list(argv)
    for i in range(len(argv) - 1):      # "--bins -40:400:40": a value, not an option
        if argv[i] in ("--bins", "--section-range") and argv[i + 1][:2].lstrip("-")[:1].isdigit() \
                and argv[i + 1].startswith("-"):
            argv[i:i + 2] = [f"{argv[i]}={argv[i + 1]}", ""]
    argv = [a for a in argv if a != ""]
    ap = argparse.ArgumentParser(
        prog="python -m tubes.experiment",
        description="Transition fractions from tracked trajectories (docs/experiment.md).")
    ap.add_argument("tracks", help="CSV (track,t,x,y; s, cm) or HDF5 (/tracks) file")
    ap.add_argument("--theory", help="tubes RESULT.h5 with /section, /transition (and /tubes)")
    ap.add_argument("-o", "--output", help="write the analysis to this HDF5 file")
    ap.add_argument("--figure", help="draw the paper's Fig. 4 into this PNG file")
    ap.add_argument("--estimator", choices=ESTIMATORS, default="spectral")
    ap.add_argument("--window", type=_integer, help="savgol window [samples, odd] (default 15)")
    ap.add_argument("--order", type=_integer, help="savgol polynomial order (default 4)")
    ap.add_argument("--cutoff", type=_number, help="spectral low-pass cutoff [Hz] (default 5)")
    ap.add_argument("--edge", choices=("odd", "mirror", "periodic"),
                    help="spectral edge handling (default odd)")
    ap.add_argument("--energy", choices=("window", "instant"), default="window",
                    help="energy at a crossing: windowed regression (default) or instantaneous")
    ap.add_argument("--energy-window", type=_positive, default=ENERGY_WINDOW,
                    help=f"half-width of the energy regression [s] (default {ENERGY_WINDOW})")
    ap.add_argument("--bins", type=_parse_bins, default=None,
                    help="dE bin edges: START:STOP:STEP or e1,e2,... [(cm/s)^2] (default -40:400:40)")
    ap.add_argument("--fit-max", type=_positive, default=160.0,
                    help="bins within (0, FIT_MAX] enter the slope fit (default 160)")
    ap.add_argument("--confidence", type=_number, default=0.95, help="interval level (default 0.95)")
    ap.add_argument("--t-skip", type=_positive, default=T_SKIP, help="dropped at each track start [s]")
    ap.add_argument("--gate", type=_positive, default=GATE, help="transition: x < x_S12 - GATE [cm]")
    ap.add_argument("--rate", type=_positive, default=0.0, help="camera rate [Hz] (default: file)")
    ap.add_argument("--columns", type=_parse_columns, default=None,
                    help="the file's column names: track=NAME,t=NAME,x=NAME,y=NAME (any subset)")
    ap.add_argument("--time-unit", choices=TIME_UNIT_CHOICES, default="s",
                    help="unit of the times: s, ms, us, or frame (frame indices; needs --rate, frames per second)")
    ap.add_argument("--length-unit", choices=tuple(LENGTH_UNITS), default="cm",
                    help="unit of x and y (px needs --pixel-size)")
    ap.add_argument("--pixel-size", type=_positive, default=None, help="cm per pixel (--length-unit px)")
    ap.add_argument("--origin", type=_parse_pair, default=None,
                    help="the plate centre X,Y in the file's frame and length unit")
    ap.add_argument("--rotate", type=_number, default=None,
                    help="rotate the file's frame by this angle [deg, counter-clockwise] onto the surface's")
    ap.add_argument("--flip-y", action="store_true", help="the file's y axis points down (image rows)")
    ap.add_argument("--max-impossible", type=_positive, default=0.005,
                    help="refuse when more than this fraction of the samples lie higher than their track's "
                         "energy allows (default 0.005; correct data: none)")
    ap.add_argument("--calibration", default=None,
                    help="CSV of known points camera_x,camera_y,surface_x,surface_y (camera in the "
                         "file's length unit, surface in cm): origin, rotation and flip fitted, residual printed")
    ap.add_argument("--noise", type=_positive, default=0.0,
                    help="position noise [cm] for dE_err (default: estimated from the data)")
    ap.add_argument("--plate", type=_positive, default=PLATE, help="plate half-width [cm]")
    ap.add_argument("--guard", type=_positive, default=0.0,
                    help="crossings within GUARD s of a segment end count as censored (default 0)")
    ap.add_argument("--resamples", type=_count(MAX_RESAMPLES), default=16,
                    help=f"noise realisations for dE_err (default 16, at most {MAX_RESAMPLES})")
    ap.add_argument("--bootstrap", type=_count(MAX_BOOTSTRAP), default=400,
                    help=f"track bootstrap replicates (default 400, at most {MAX_BOOTSTRAP})")
    ap.add_argument("--cut-rule", choices=("at-or-above", "nearest", "bin-top"), default="at-or-above",
                    help="tube cut for a crossing: the first at or above its dE (default), the "
                         "nearest, or the first at or above its bin's upper edge (the paper's)")
    ap.add_argument("--fold", choices=tuple(FOLDS), default="none",
                    help="none: U1^- only (default); exact: also U1^+ and both ways through quadrant 3's "
                         "diagonal (the surface's symmetries: the same theory); all: also quadrants 2 and "
                         "4 (shallower wells: counted and tabulated apart, q24_*)")
    ap.add_argument("--theory-q24", default=None,
                    help="with --fold all: a tubes RESULT.h5 on the diagonal of quadrant 2 (&orbits saddle = "
                         "'S23', &section angle = 135) for the q24 table's theory")
    ap.add_argument("--section-range", type=_parse_range, default=(40.0, 140.0),
                    help="dE range of the section plot (default 40,140)")
    ap.add_argument("--decay-drift", action="store_true",
                    help="the rolling and combined fits of the energy's decay also take a drift beta t, as the "
                         "viscous one (robust to a slow drift of the energy estimate; 4-7 times the errors)")
    ap.add_argument("--dissipation-figure", default=None,
                    help="draw the energy loss against time, path length and D per segment into this PNG file")
    ap.add_argument("--strict", action="store_true",
                    help="exit with status 1 if any track was rejected or any sample dropped")
    ap.add_argument("--all-issues", action="store_true",
                    help="print every issue found in the tracks (default: a count per kind and the "
                         f"first {SHOWN_ISSUES} of each; all are in the output's /experiment/validation)")
    args = ap.parse_args(argv)
    # a reader that stops early (| head) ends this program quietly, its files still written
    with contextlib.redirect_stdout(_QuietPipe(sys.stdout)):
        return _main(args, orig)


class _QuietPipe(io.TextIOBase):
    """stdout that turns a broken pipe into silence (the rest of the run goes on)."""

    def __init__(self, stream):
        self.stream = stream
        self.broken = False

    def write(self, s):
        if not self.broken:
            try:
                self.stream.write(s)
                self.stream.flush()
            except BrokenPipeError:
                self.broken = True
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, self.stream.fileno())     # Python's own flush at exit stays quiet
                os.close(devnull)
        return len(s)

    def flush(self):
        pass


SHOWN_ISSUES = 3     # issues printed per kind unless --all-issues


def _print_issues(rep: "ValidationReport", all_issues: bool) -> None:
    """The issues on stderr: every one, or per kind its count and the first SHOWN_ISSUES."""
    by_kind = {}
    for i in rep.issues:
        by_kind.setdefault((i.severity, i.kind), []).append(i)
    for (sev, kind), items in by_kind.items():
        shown = items if all_issues else items[:SHOWN_ISSUES]
        if not all_issues and len(items) > 1:
            print(f"{sev}: {len(items)} issue(s) of kind {kind} ({sum(i.n_samples for i in items)} samples); "
                  f"the first {len(shown)}:", file=sys.stderr)
        for i in shown:
            print(f"{sev}: {i.message}", file=sys.stderr)
        if len(items) > len(shown):
            print(f"{sev}: ... and {len(items) - len(shown)} more of kind {kind} (--all-issues prints them; all "
                  "are in the output's /experiment/validation)", file=sys.stderr)


def _outputs(args) -> list:
    """The run's output files [(option, path)], checked before any work: each a regular file or
    new (tubes._output.check_target: OutputError, exit 3), none of them an input file or another
    output (ExperimentError, exit 1)."""
    outs = [(o, p) for o, p in (("-o", args.output), ("--figure", args.figure),
                                ("--dissipation-figure", args.dissipation_figure)) if p]
    seen = {}
    inputs = [(o, p) for o, p in (("TRACKS", args.tracks), ("--theory", args.theory),
                                  ("--theory-q24", args.theory_q24), ("--calibration", args.calibration)) if p]
    for o, p in outs:
        real = os.path.realpath(_output.check_target(p, o))
        for io_, ip in inputs:
            if os.path.exists(ip) and os.path.realpath(ip) == real:
                raise ExperimentError(f"{o} '{p}' is the input file {ip} ({io_}): it would be overwritten; "
                                      "give another name")
        if real in seen:
            raise ExperimentError(f"{o} '{p}' and {seen[real]} name the same file: give each output its own name")
        seen[real] = f"{o} '{p}'"
        if o != "-o":
            _output.check_figure_format(p, o)
    return outs


def _main(args, orig) -> int:
    try:
        _outputs(args)
    except _output.OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return _output.EXIT_IO
    except ExperimentError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    _output.handle_sigterm()
    try:
        return _run(args, orig)
    except KeyboardInterrupt as exc:
        return _output.interrupted(exc, "python -m tubes.experiment")


def _run(args, orig) -> int:
    try:
        if not 0 < args.confidence < 1:
            raise ExperimentError("--confidence must lie in (0, 1)")
        if args.resamples < 0 or args.bootstrap < 0:
            raise ExperimentError("--resamples and --bootstrap must be >= 0")
        if not args.noise <= args.plate:
            raise ExperimentError(f"--noise {args.noise:g}: the position noise [cm] must lie in 0 .. the plate's "
                                  f"half-width {args.plate:g} cm (--plate)")
        est_opts = dict(DEFAULT_OPTIONS[args.estimator])
        if args.estimator == "savgol":
            if args.window is not None:
                est_opts["window"] = args.window
            if args.order is not None:
                est_opts["order"] = args.order
            if est_opts["window"] % 2 == 0 or est_opts["window"] < 5 or not \
                    0 < est_opts["order"] < est_opts["window"] - 1:
                raise ExperimentError("savgol: need an odd window >= 5 and 0 < order < window - 1")
        else:
            if args.cutoff is not None:
                if not args.cutoff > 0:
                    raise ExperimentError("--cutoff must be > 0")
                est_opts["cutoff"] = args.cutoff
            if args.edge is not None:
                est_opts["edge"] = args.edge
        theory = load_theory(args.theory) if args.theory else None
        theory_q24 = load_theory(args.theory_q24, diagonal=2) if args.theory_q24 else None
        opt = Options(estimator=args.estimator, estimator_options=est_opts, energy=args.energy,
                      energy_window=args.energy_window, t_skip=args.t_skip, gate=args.gate,
                      plate=args.plate, rate=args.rate, noise=args.noise,
                      confidence=args.confidence, fit_max=args.fit_max, guard=args.guard,
                      resamples=args.resamples, bootstrap=args.bootstrap, cut_rule=args.cut_rule,
                      max_impossible=args.max_impossible, fold=args.fold, decay_drift=args.decay_drift)
        if args.bins is not None:
            opt.bins = args.bins
        cal = None
        if args.calibration and (args.origin is not None or args.rotate is not None or args.flip_y):
            raise ExperimentError("--calibration fits origin, rotation and flip: do not also give --origin, "
                                  "--rotate or --flip-y")
        if args.calibration:
            cal = read_calibration(args.calibration, args.length_unit, args.pixel_size)
            if not cal.residual <= CAL_RESIDUAL_MAX:
                raise ExperimentError(f"{args.calibration}: the known points do not fit a rotation, shift and flip: "
                                      f"residual rms {cal.residual:.3g} cm > {CAL_RESIDUAL_MAX} cm (wrong "
                                      "--length-unit, a point mistyped, or a camera seen at an angle?)")
        elif args.origin is not None or args.rotate is not None or args.flip_y:
            sc = _length_scale(args.length_unit, args.pixel_size)
            o = args.origin or (0.0, 0.0)
            cal = Calibration((o[0] * sc, o[1] * sc), args.rotate or 0.0, args.flip_y)
        tracks = read_tracks(args.tracks, columns=args.columns, time_unit=args.time_unit,
                             length_unit=args.length_unit, pixel_size=args.pixel_size, calibration=cal,
                             rate=args.rate or None)
        an = analyse(tracks, theory, opt, theory_q24=theory_q24)
    except ExperimentError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except MemoryError:
        nb = len(args.bins or Options.bins) - 1
        print(f"error: not enough memory for the analysis of {args.tracks} (--bins {nb} bins, --resamples "
              f"{args.resamples}, --bootstrap {args.bootstrap}: smaller values need less)", file=sys.stderr)
        return 1
    rep = an.report
    if cal is not None:
        print(cal.describe())
    print(f"camera rate {an.attrs['camera_rate']:.6g} Hz ({'--rate' if args.rate else 'from the file'}); times in "
          f"{'frames (divided by --rate)' if args.time_unit == 'frame' else args.time_unit}, lengths in "
          f"{args.length_unit}")
    if tracks.attrs.get("rows_reordered"):
        print(f"note: {tracks.attrs['rows_reordered']} rows were not in (track, time) order: sorted "
              f"(a file may list its rows in any order; a track whose time decreases over most of it is rejected)",
              file=sys.stderr)
    _print_issues(rep, args.all_issues)
    a = an.attrs
    print(rep.summary())
    if a["fold"] == "none":
        print(f"U1 crossings: {a['n_u1_crossings']} ({a['n_u1_minus']} U1^-, {a['n_u1_plus']} U1^+); "
              f"U1^- classified: {a['n_crossings']} in the bins, {a['n_transitions']} transitions, "
              f"{a['n_censored']} censored, {a['n_edge']} at segment edges")
    else:
        print(f"crossings of {FOLD_TEXT[a['fold']]}: {a['n_u1_minus']} (each once, as U1^- of its image); "
              f"{a['n_censored']} censored, {a['n_edge']} at segment edges")
    if a["fold"] != "none":
        line = (f"folded ({a['fold']}: {FOLD_TEXT[a['fold']]}): {a['n_folded_crossings']} crossings "
                f"classified at any energy, {a['n_folded_transitions']} transitions; in the bins: quadrants 1 "
                f"and 3 {a['n_crossings']} crossings, {a['n_transitions']} transitions")
        if "q24_n_crossings" in a:
            line += f"; quadrants 2 and 4 {a['q24_n_crossings']}, {a['q24_n_transitions']} (their own column)"
        print(line)
        if math.isfinite(a.get("q24_slope", math.nan)) and "q24_slope_theory" in a:
            print(f"quadrants 2 and 4: slope ({a['q24_slope'] * 1e3:.3f} +- {a['q24_slope_err'] * 1e3:.3f})e-3 "
                  f"(s/cm)^2; their theory with the same weights {a['q24_slope_theory'] * 1e3:.3f}e-3")
    print(f"estimator {a['estimator']} {a['estimator_options']} ({a['differentiator']}), energy "
          f"{a['energy_method']}; position noise {a['noise_used']:.4f} cm; design effect "
          f"{a['design_effect']:.2f}")
    if "slope_upper_95" in a:
        print(slope_text(a))
    elif math.isfinite(a.get("slope", math.nan)):
        line = f"slope (through the origin, dE <= {a['fit_max']:g}): " + slope_text(a).removeprefix("slope ")
        if "slope_theory" in a:
            line += f"; theory with the same weights {a['slope_theory'] * 1e3:.3f}e-3, T_po/A0 = " \
                    f"{a['growth_rate'] * 1e3:.4f}e-3"
        print(line)
        if "fit_note" in a:
            print(f"note: {a['fit_note']}")
    else:
        print(f"no slope: no bin with crossings inside the fit range (0, {a['fit_max']:g}] of the bins")
    if math.isfinite(a.get("inside_fraction", math.nan)):
        print(f"transitions inside the tube cut ({a['cut_rule']}): {a['n_transitions_inside']} of "
              f"{a['n_inside_evaluated']} = {a['inside_fraction']:.3%}")
    if math.isfinite(a.get("damping_rate", math.nan)):
        z = _z(a["confidence"])
        print(f"damping from the energy's decay (dE/dt = -2 c T): c = "
              f"{_pm(a['damping_rate'], a['damping_rate_err'], '.5g', unit=' 1/s')}, zeta = "
              f"{_pm(a['damping_ratio'], a['damping_ratio_err'], '.5g', z=z, conf=a['confidence'])}")
    if math.isfinite(a.get("combined_damping_rate", math.nan)):
        for line in _dissipation_summary(a):
            print(line)
    if math.isfinite(a.get("damping_rate", math.nan)) and not math.isfinite(a.get("damping_rate_err", math.nan)):
        print("note: no error on the decay's coefficients: they come from a bootstrap over the tracks, which "
              "needs two or more")
    if math.isfinite(a["energy_balance"]):
        print(f"energy balance along the tracks: g H falls by {a['energy_balance']:.4f} times what T gains "
              f"(1 for positions, times and surface that agree)")
    else:
        print("energy balance along the tracks: undetermined (no segment with 8 usable samples of T and E)")
    if "truth_dE_rms" in a:
        print(f"against the truth: dE rms {a['truth_dE_rms']:.2f}, bias {a['truth_dE_bias']:+.2f} "
              f"(cm/s)^2, z rms {a['truth_dE_z_rms']:.2f}; outcome agreement "
              f"{a['truth_outcome_agreement']:.4f}")
    b = an.bins
    q24 = "q24_count" in b
    print("      dE bin     center   count  trans  fraction     interval        theory" +
          ("   | Q2+Q4: count  trans  fraction    theory" if q24 else ""))
    def cell(v, width=8):       # an empty bin has no fraction, a bin outside the theory's range no p: "-", not nan
        return f"{v:{width}.4f}" if math.isfinite(v) else f"{'-':>{width}}"

    for j in range(b["count"].size):
        ci = (f"[{b['ci_low'][j]:.4f}, {b['ci_high'][j]:.4f}]" if math.isfinite(b["ci_low"][j])
              else f"{'-':^16}")
        print(f"{b['dE_low'][j]:7.0f}..{b['dE_high'][j]:<5.0f} {b['dE_center'][j]:8.1f} {b['count'][j]:7d} "
              f"{b['transitions'][j]:6d}  {cell(b['fraction'][j])}  {ci}  {cell(b['p_theory'][j])}" +
              (f"   |      {b['q24_count'][j]:7d} {b['q24_transitions'][j]:6d}  {cell(b['q24_fraction'][j])}  "
               f"{cell(b['q24_p_theory'][j])}" if q24 else ""))
    try:
        with _output.batch():      # every output made first, then written all or none
            if args.output:
                write_analysis(args.output, an, ["python -m tubes.experiment", *orig], args.tracks, option="-o")
            if args.figure:
                plot_analysis(args.figure, an, args.section_range, option="--figure")
            if args.dissipation_figure:
                plot_dissipation(args.dissipation_figure, an, option="--dissipation-figure")
    except _output.OutputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return _output.EXIT_IO
    for p in (args.output, args.figure, args.dissipation_figure):
        if p:
            print(f"wrote {p}")
    if args.strict and rep.issues:
        print(f"error: --strict: {len(rep.issues)} issue(s) in the tracks", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
