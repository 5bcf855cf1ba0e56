"""The lab-style example input/lab_tracks.csv and input/lab_calibration.csv (docs/experiment.md,
"A lab file, step by step"): synthetic tracks of the paper's set-up (damped balls released from
rest, 50 Hz, 0.05 cm noise, 0.16 cm pixels) written the way a tracker writes them: rows by frame,
';' separators, its own column names, times in ms, lengths in mm, the image's y axis pointing
down, the origin at the plate's corner and the camera turned by 2 degrees; and the four wells'
positions in that frame as the known points of the calibration.

    .venv/bin/python tests/lab_example.py      # rewrites both files (deterministic)
"""
import math
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "python"))

import tubes  # noqa: E402
import tubes.experiment as ex  # noqa: E402

ORIGIN_MM = (150.0, 150.0)      # the plate centre in the image, mm from the corner
ANGLE = 2.0                     # [deg] the surface frame is the image frame turned by this


def to_camera(x, y):
    """Surface [cm] -> image [mm], y down: the inverse of the calibration."""
    a = math.radians(ANGLE)
    u = math.cos(a) * np.asarray(x) + math.sin(a) * np.asarray(y)     # R(-angle)
    v = -math.sin(a) * np.asarray(x) + math.cos(a) * np.asarray(y)
    return 10 * u + ORIGIN_MM[0], -10 * v + ORIGIN_MM[1]


def main():
    tr = ex.synthetic_tracks(8, duration=6.0, damping_ratio=0.025, seed=2018, noise=0.05, pixel=0.16, rate=50.0)
    xm, ym = to_camera(tr.x, tr.y)
    rows = sorted(zip(np.round(tr.t * 50).astype(int), tr.track, tr.t * 1e3, xm, ym))
    with open(ROOT / "input" / "lab_tracks.csv", "w") as f:
        f.write("frame;time_ms;x_mm;y_mm;id\n")
        f.writelines(f"{fr};{t:.3f};{x:.4f};{y:.4f};{k}\n" for fr, k, t, x, y in rows)
    eq = tubes.equilibria(tubes.Model())
    wells = [i for i, n in enumerate(eq["name"]) if str(n).startswith("W")]
    with open(ROOT / "input" / "lab_calibration.csv", "w") as f:
        f.write("camera_x_mm,camera_y_mm,surface_x_cm,surface_y_cm\n")
        for i in wells:
            cx, cy = to_camera(eq["x"][i], eq["y"][i])
            f.write(f"{float(cx):.4f},{float(cy):.4f},{eq['x'][i]:.6f},{eq['y'][i]:.6f}\n")


if __name__ == "__main__":
    main()
