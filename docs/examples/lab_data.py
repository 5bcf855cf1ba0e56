"""The lab-data walkthrough in Python (docs/experiment.md): tracks as a camera gives them, read,
checked and analysed by tubes.experiment, with the damping measured from the energy's decay.

The tracks are synthetic (tubes.experiment.synthetic_tracks: the paper's ball released from rest
at dE in 1000..2000 (cm/s)^2 with damping ratio zeta = 0.025, sampled at 50 Hz, 0.05 cm noise,
0.16 cm pixels), written as a trackpy-style CSV (frame, particle, x, y in pixels, y down) and
read back with time_unit='frame' and the rate, the pixel size and the flipped y axis, as
`python -m tubes.experiment tracks.csv --time-unit frame --rate 50 --columns t=frame,track=particle
--length-unit px --pixel-size 0.16 --flip-y` does. 12 tracks of 8 s (the paper's set has 600):
about 3 s. The printed damping ratio must hold the true 0.025 inside its 95 % interval.

    .venv/bin/python docs/examples/lab_data.py [OUTDIR]   (writes OUTDIR/lab_tracks.csv, lab_data.png)
"""
import os
import sys

import tubes.experiment as ex

ZETA, RATE, PIXEL = 0.025, 50.0, 0.16


def main(outdir="."):
    tr = ex.synthetic_tracks(12, duration=8.0, damping_ratio=ZETA, seed=11, noise=0.05, pixel=PIXEL, rate=RATE)
    csv = os.path.join(outdir, "lab_tracks.csv")
    with open(csv, "w") as f:                        # what a tracker exports: frames, pixels, y down
        f.write("frame,particle,x,y\n")
        f.writelines(f"{round(t * RATE)},{k},{float(x) / PIXEL!r},{-float(y) / PIXEL!r}\n"
                     for k, t, x, y in zip(tr.track, tr.t, tr.x, tr.y))
    tracks = ex.read_tracks(csv, columns={"t": "frame", "track": "particle"}, time_unit="frame", rate=RATE,
                            length_unit="px", pixel_size=PIXEL, calibration=ex.Calibration((0.0, 0.0), 0.0, True))
    an = ex.analyse(tracks, None, ex.Options(bootstrap=200, resamples=0, compare=False))
    a, rep = an.attrs, an.report
    print(f"{tracks.track.max() + 1} tracks, {tracks.t.size} samples at {a['camera_rate']:g} Hz; "
          f"{rep.n_segments} segments analysed")
    print(f"energy balance: g H falls by {a['energy_balance']:.4f} times what T gains (1 when units and frame agree)")
    print(f"U1^- crossings {a['n_crossings']}, transitions {a['n_transitions']}")
    lo, hi = a["damping_ratio"] - 1.96 * a["damping_ratio_err"], a["damping_ratio"] + 1.96 * a["damping_ratio_err"]
    print(f"damping ratio zeta = {a['damping_ratio']:.5f} +- {a['damping_ratio_err']:.5f} "
          f"(95 %: {lo:.5f} .. {hi:.5f}; true {ZETA})")
    path = os.path.join(outdir, "lab_data.png")
    ex.plot_dissipation(path, an)
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
