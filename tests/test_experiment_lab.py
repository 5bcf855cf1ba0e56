"""Tracks written the way lab software writes them (issue 17, "getting data in"): times in ms,
positions in mm, m or pixels, other column names, ';' or tab separators, rows ordered by frame.
With the right options the reader returns the canonical file's samples (to round-off) and the
analysis prints the canonical numbers; without them the run refuses and names the option."""
import os
import re
import subprocess

import numpy as np
import pytest

import tubes.experiment as ex
from conftest import ROOT

PY = str(ROOT / ".venv" / "bin" / "python")


def _run(args, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT / "python"))
    return subprocess.run([PY, "-m", "tubes.experiment", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300, env=env)


@pytest.fixture(scope="module")
def canon(tmp_path_factory):
    d = tmp_path_factory.mktemp("lab")
    tr = ex.synthetic_tracks(6, duration=4.0, ensemble="microcanonical", dE_range=(100.0, 300.0),
                             seed=5, noise=0.05, pixel=0.16, rate=50.0)
    rows = list(zip(tr.track.tolist(), tr.t.tolist(), tr.x.tolist(), tr.y.tolist()))
    with open(d / "canon.csv", "w") as f:
        f.write("track,t,x,y\n")
        f.writelines(f"{k},{t!r},{x!r},{y!r}\n" for k, t, x, y in rows)
    return d, rows


def _lab(path, rows, tscale=1.0, lscale=1.0, sep=",", header=("track", "t", "x", "y"),
         by_frame=False, frame=False):
    """Write rows as a tracker would: times x tscale, lengths x lscale, named columns, a frame
    column first, rows ordered by frame (time) instead of by track."""
    out = sorted(rows, key=lambda r: (r[1], r[0])) if by_frame else rows
    with open(path, "w") as f:
        f.write(sep.join((["frame"] if frame else []) + list(header)) + "\n")
        for k, t, x, y in out:
            cells = [str(int(round(t * 50)))] if frame else []
            cells += [str(k), repr(t * tscale), repr(x * lscale), repr(y * lscale)]
            f.write(sep.join(cells) + "\n")


def _same(tr, rows):
    k, t, x, y = (np.array(c) for c in zip(*rows))
    assert np.array_equal(tr.track, k)
    np.testing.assert_allclose(tr.t, t, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(tr.x, x, rtol=1e-15, atol=1e-14)
    np.testing.assert_allclose(tr.y, y, rtol=1e-15, atol=1e-14)


CASES = [  # (name, writer kwargs, reader kwargs)
    ("ms", dict(tscale=1e3), dict(time_unit="ms")),
    ("us", dict(tscale=1e6), dict(time_unit="us")),
    ("mm", dict(lscale=10.0), dict(length_unit="mm")),
    ("m", dict(lscale=0.01), dict(length_unit="m")),
    ("px", dict(lscale=1 / 0.16), dict(length_unit="px", pixel_size=0.16)),
    ("semicolon", dict(sep=";"), {}),
    ("tab", dict(sep="\t"), {}),
    ("by frame", dict(by_frame=True), {}),
    ("lab header", dict(header=("track_id", "time_s", "x_cm", "y_cm"), frame=True),
     dict(columns={"track": "track_id", "t": "time_s", "x": "x_cm", "y": "y_cm"})),
    ("all at once", dict(tscale=1e3, lscale=10.0, sep=";", by_frame=True, frame=True,
                         header=("id", "ms", "xmm", "ymm")),
     dict(time_unit="ms", length_unit="mm", columns={"track": "id", "t": "ms", "x": "xmm", "y": "ymm"})),
]


@pytest.mark.parametrize("name,wk,rk", CASES, ids=[c[0] for c in CASES])
def test_the_reader_returns_the_canonical_samples(canon, tmp_path, name, wk, rk):
    d, rows = canon
    _lab(tmp_path / "lab.csv", rows, **wk)
    _same(ex.read_tracks(str(tmp_path / "lab.csv"), **rk), rows)


def _numbers(out):
    """The analysis' result lines, without the camera-rate line that names the units."""
    return [ln for ln in out.splitlines() if not ln.startswith("camera rate")]


def test_the_analysis_of_a_lab_file_with_its_options_is_the_canonical_one(canon, tmp_path):
    d, rows = canon
    ref = _run([str(d / "canon.csv")], tmp_path)
    assert ref.returncode == 0, ref.stderr
    assert "camera rate 50 Hz (from the file)" in ref.stdout
    _lab(tmp_path / "lab.csv", rows, **CASES[-1][1])
    r = _run(["lab.csv", "--time-unit", "ms", "--length-unit", "mm", "--columns",
              "track=id,t=ms,x=xmm,y=ymm"], tmp_path)
    assert r.returncode == 0, r.stderr
    assert "camera rate 50 Hz (from the file); times in ms, lengths in mm" in r.stdout
    num = re.compile(r"[-+]?\d+\.\d+(?:e[-+]?\d+)?")
    a, b = _numbers(ref.stdout), _numbers(r.stdout)
    assert len(a) == len(b)
    for la, lb in zip(a, b):       # the same numbers to round-off (unit conversion of the inputs)
        xa, xb = [float(v) for v in num.findall(la)], [float(v) for v in num.findall(lb)]
        assert len(xa) == len(xb) and num.sub("#", la) == num.sub("#", lb), (la, lb)
        np.testing.assert_allclose(xb, xa, rtol=1e-6, atol=1e-9)


REFUSALS = [  # (name, writer kwargs, extra args, substrings of the message)
    ("ms read as s", dict(tscale=1e3), [], ["camera rate 0.05 Hz", "--time-unit ms"]),
    ("metres read as cm", dict(lscale=0.01), [], ["within", "of the plate's centre", "--length-unit m"]),
    ("mm read as cm", dict(lscale=10.0), [], ["off the plate", "--length-unit"]),
    ("origin at the corner", dict(), ["--columns", "x=xs"], []),
    ("lab header without --columns", dict(header=("track_id", "time_s", "x_cm", "y_cm")), [],
     ["missing track, t, x, y", "--columns"]),
    ("px without a size", dict(), ["--length-unit", "px"], ["--pixel-size"]),
]


@pytest.mark.parametrize("name,wk,extra,needles", REFUSALS, ids=[c[0] for c in REFUSALS])
def test_without_the_options_the_run_refuses_and_names_the_cause(canon, tmp_path, name, wk, extra, needles):
    d, rows = canon
    if name == "origin at the corner":          # x, y measured from the plate's corner
        with open(tmp_path / "lab.csv", "w") as f:
            f.write("track,t,x,y,xs\n")
            f.writelines(f"{k},{t!r},{x + 15.0!r},{y + 15.0!r},0\n" for k, t, x, y in rows)
        extra, needles = [], ["off the plate", "origin"]
    else:
        _lab(tmp_path / "lab.csv", rows, **wk)
    r = _run(["lab.csv", "-o", "an.h5", *extra], tmp_path)
    assert r.returncode == 1, (r.returncode, r.stdout, r.stderr)
    for n in needles:
        assert n in r.stderr, (n, r.stderr)
    assert not (tmp_path / "an.h5").exists()
