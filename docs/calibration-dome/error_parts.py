"""What the surface fit's error is made of, by tilt and depth, and the slides' shear by depth.

Reads a `cargo xtask real-compare --dump FILE` of the surface recordings. Per recording, the
mean pin error over the mean real motion (the fit's relative error) and what is left of it
after mapping the simulated field onto the real one by (a) its global shift (the median pin
motion) moved onto the real one, (b) the best similarity (shift, scale and turn in the image)
and (c) the best affine map; then the global shift's size, real against simulated, by depth,
and for presses tilted under 12 deg by depth and slide distance (`shear_x`, `shear_y`).

    python3 docs/calibration-dome/error_parts.py WORK/dump.json
"""

import json
import sys

import numpy as np

TILTS = [(0, 5), (5, 10), (10, 15), (15, 20), (20, 26)]
DEPTHS = [(1, 2), (2, 3), (3, 4), (4, 5.1)]
SLIDES = [(0, 1), (1, 2), (2, 3), (3, 7.1)]


def field(values):
    return np.array([[np.nan, np.nan] if v is None else v for v in values], dtype=float)


def parts(real, sim):
    """Relative error as is, after (a), (b), (c); the two global shifts (px)."""
    norm = np.linalg.norm(real, axis=1).mean()
    err = lambda f: np.linalg.norm(f - real, axis=1).mean() / norm  # noqa: E731
    shifted = sim - np.median(sim, axis=0) + np.median(real, axis=0)
    zr, zs = real[:, 0] + 1j * real[:, 1], sim[:, 0] + 1j * sim[:, 1]
    a = np.stack([zs, np.ones_like(zs)], axis=1)
    similar = a @ np.linalg.lstsq(a, zr, rcond=None)[0]
    b = np.c_[sim, np.ones(len(sim))]
    affine = b @ np.linalg.lstsq(b, real, rcond=None)[0]
    return (err(sim), err(shifted), np.abs(similar - zr).mean() / norm, err(affine),
            np.linalg.norm(np.median(real, axis=0)), np.linalg.norm(np.median(sim, axis=0)))


def main(path):
    rows = []
    for s in json.load(open(path))["samples"]:
        pose, shear = s["pose"], s["shear"]
        real, sim = field(s["real"]), field(s["sim"])
        ok = ~np.isnan(real).any(axis=1) & ~np.isnan(sim).any(axis=1)
        rows.append((np.hypot(pose[3], pose[4]), pose[2], np.hypot(shear[0], shear[1]), *parts(real[ok], sim[ok])))
    rows = np.array(rows)
    tilt, depth, slide = rows[:, 0], rows[:, 1], rows[:, 2]
    band = lambda v, lo, hi: (v >= lo) & (v < hi)  # noqa: E731
    print("relative error: as is / shift moved / similarity / affine")
    print("tilt (deg)   n    " + "   ".join("depth %g-%g mm" % (lo, int(hi)) for lo, hi in DEPTHS))
    for lo, hi in TILTS:
        cells = []
        for dlo, dhi in DEPTHS:
            m = band(tilt, lo, hi) & band(depth, dlo, dhi)
            cells.append("%3d %.3f/%.3f/%.3f/%.3f" % (m.sum(), *rows[m, 3:7].mean(axis=0)) if m.any() else " " * 27)
        print("%2d-%2d  %s" % (lo, hi, "  ".join(cells)))
    m = np.ones(len(rows), dtype=bool)
    print("all   %d %.3f/%.3f/%.3f/%.3f" % (m.sum(), *rows[:, 3:7].mean(axis=0)))
    print("global shift (px), real / simulated, by depth: " + ", ".join(
        "%g-%g mm %.2f / %.2f" % (lo, int(hi), *rows[band(depth, lo, hi), 7:9].mean(axis=0)) for lo, hi in DEPTHS))
    print("tilt under 12 deg, global shift (px) real / simulated by depth (rows) and slide (mm, columns)")
    for dlo, dhi in DEPTHS:
        cells = []
        for slo, shi in SLIDES:
            m = (tilt < 12) & band(depth, dlo, dhi) & band(slide, slo, shi)
            cells.append("%g-%g: %2d %5.2f / %5.2f" % (slo, int(shi), m.sum(), *rows[m, 7:9].mean(axis=0))
                         if m.any() else "%g-%g:  0" % (slo, int(shi)))
        print("%g-%g mm  %s" % (dlo, int(dhi), "   ".join(cells)))


if __name__ == "__main__":
    main(sys.argv[1])
