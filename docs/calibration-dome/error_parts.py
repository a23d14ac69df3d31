"""What the surface fit's error is made of, by tilt and depth, and the slides' shear by depth.

Reads a `cargo xtask real-compare --dump FILE` of the surface recordings. Per recording, the
mean pin error over the mean real motion (the fit's relative error) and what is left of it
after mapping the simulated field onto the real one by (a) its global shift (the median pin
motion) moved onto the real one, (b) the best similarity (shift, scale and turn in the image)
and (c) the best affine map; then the global shift's size, real against simulated, by depth,
and for presses tilted under 12 deg by depth and slide distance (`shear_x`, `shear_y`); last,
the pins' mean motion (px), real against simulated, by distance from the real pressed region's
centre (`contact_centres.py`'s), for the shallow (1-2 mm) presses tilted over 15 deg and for
the 2-4 mm presses tilted under 10 deg.

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


def reach(path):
    """Mean pin motion (px), real / simulated, by distance (px) from the pressed region."""
    dump = json.load(open(path))
    reference = np.array(dump["reference"], dtype=float)
    groups = {"1-2 mm, tilt over 15 deg": lambda t, d: t >= 15 and 1 <= d < 2,
              "2-4 mm, tilt under 10 deg": lambda t, d: t < 10 and 2 <= d < 4}
    edges = np.arange(0, 280, 40)
    for name, keep in groups.items():
        sums = np.zeros((len(edges), 3))
        for s in dump["samples"]:
            pose = s["pose"]
            if not keep(np.hypot(pose[3], pose[4]), pose[2]):
                continue
            real, sim = field(s["real"]), field(s["sim"])
            ok = ~np.isnan(real).any(axis=1) & ~np.isnan(sim).any(axis=1)
            w = np.linalg.norm(real - np.median(real[ok], axis=0), axis=1)
            w[~ok] = 0.0
            top = np.where(w >= np.quantile(w[ok], 0.9), w, 0.0)
            centre = (reference * top[:, None]).sum(axis=0) / top.sum()
            far = np.minimum(np.linalg.norm(reference - centre, axis=1) // 40, len(edges) - 1).astype(int)
            for k in np.where(ok)[0]:
                sums[far[k]] += (1.0, np.linalg.norm(real[k]), np.linalg.norm(sim[k]))
        print("%s: mean pin motion (px) real / simulated by distance from the pressed region" % name)
        print("  " + ", ".join("%d-%d px %.2f / %.2f" % (e, e + 40, r / n, m / n)
                               for e, (n, r, m) in zip(edges, sums) if n > 0))


if __name__ == "__main__":
    main(sys.argv[1])
    reach(sys.argv[1])
