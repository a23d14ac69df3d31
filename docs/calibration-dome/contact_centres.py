"""Where the pressed region sits in the image, real against simulated, by tilt.

Reads a `cargo xtask real-compare --dump FILE` of the surface recordings and, per recording,
takes the centre of the pins whose displacement (less the median, the global shift) is in its
top 10%, weighted by that displacement: a stand-in for the contact's centre in the image
(px at 420 px). Prints, by tilt band, the mean distance of that centre from the image centre
(210, 210) for the real and the simulated fields, the mean distance between the two, and the
mean relative error (mean pin error over mean real motion); then the same for tilts over
15 deg by depth band.

    python3 docs/calibration-dome/contact_centres.py WORK/dump.json
"""

import json
import sys

import numpy as np


def field(values):
    return np.array([[np.nan, np.nan] if v is None else v for v in values], dtype=float)


def centre(reference, f, ok):
    shift = np.median(f[ok], axis=0)
    w = np.linalg.norm(f - shift, axis=1)
    w[~ok] = 0.0
    top = np.where(w >= np.quantile(w[ok], 0.9), w, 0.0)
    return (reference * top[:, None]).sum(axis=0) / top.sum()


def main(path):
    dump = json.load(open(path))
    reference = np.array(dump["reference"], dtype=float)
    middle = np.array([210.0, 210.0])
    rows = []
    for s in dump["samples"]:
        pose = s["pose"]
        real, sim = field(s["real"]), field(s["sim"])
        ok = ~np.isnan(real).any(axis=1) & ~np.isnan(sim).any(axis=1)
        cr, cs = centre(reference, real, ok), centre(reference, sim, ok)
        err = np.linalg.norm(sim - real, axis=1)[ok].mean() / np.linalg.norm(real[ok], axis=1).mean()
        rows.append((np.hypot(pose[3], pose[4]), pose[2], np.linalg.norm(cr - middle),
                     np.linalg.norm(cs - middle), np.linalg.norm(cr - cs), err))
    rows = np.array(rows)
    print("tilt (deg)  n    real centre  simulated  apart (px)  relative error")
    for lo, hi in [(0, 5), (5, 10), (10, 15), (15, 20), (20, 26)]:
        m = (rows[:, 0] >= lo) & (rows[:, 0] < hi)
        print("%2d-%2d     %4d   %6.1f      %6.1f     %6.1f      %.3f"
              % (lo, hi, m.sum(), *rows[m, 2:].mean(axis=0)))
    print("tilt over 15 deg, by depth (mm)")
    for lo, hi in [(1, 2), (2, 3), (3, 4), (4, 5.1)]:
        m = (rows[:, 0] >= 15) & (rows[:, 1] >= lo) & (rows[:, 1] < hi)
        print("%.0f-%.0f       %4d   %6.1f      %6.1f     %6.1f      %.3f"
              % (lo, hi, m.sum(), *rows[m, 2:].mean(axis=0)))


if __name__ == "__main__":
    main(sys.argv[1])
