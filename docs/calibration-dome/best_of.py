"""The best of several replays of the surface recordings, per depth band: an upper bound on
what a parameter that changed with the press's depth (the gel's modulus, the friction) could
give with the rig as fitted.

Reads `cargo xtask real-compare --dump FILE` dumps of the same recordings, each replayed with
one value of the parameter. Per dump, the mean relative error over all recordings (each
recording's mean pin error over its mean real motion, as the fit scores it); per depth band
(1-2 / 2-3 / 3-4 / 4-5 mm) each dump's mean and the best; last, the mean over all recordings
when each depth band, and each depth and tilt band (0-8 / 8-15 / 15-26 deg), takes its best
dump (chosen on all 600 recordings: a bound, not a fit). Needs numpy.

    python3 docs/calibration-dome/best_of.py WORK/a.json WORK/b.json ...
"""
import json
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from error_parts import DEPTHS, field  # noqa: E402

TILTS = [(0, 8), (8, 15), (15, 26)]


def errors(path):
    """Per recording: tilt (deg), depth (mm), relative error."""
    rows = []
    for s in json.load(open(path))["samples"]:
        pose = s["pose"]
        real, sim = field(s["real"]), field(s["sim"])
        ok = ~np.isnan(real).any(axis=1) & ~np.isnan(sim).any(axis=1)
        real, sim = real[ok], sim[ok]
        error = np.linalg.norm(sim - real, axis=1).mean() / np.linalg.norm(real, axis=1).mean()
        rows.append((np.hypot(pose[3], pose[4]), pose[2], error))
    return np.array(rows)


def main(paths):
    data = [errors(p) for p in paths]
    tilt, depth = data[0][:, 0], data[0][:, 1]
    errs = np.stack([d[:, 2] for d in data])
    names = [p.rsplit("/", 1)[-1] for p in paths]
    print("all recordings: " + ", ".join("%s %.4f" % (n, e.mean()) for n, e in zip(names, errs)))
    best = np.zeros(len(tilt))
    for lo, hi in DEPTHS:
        m = (depth >= lo) & (depth < hi)
        means = errs[:, m].mean(axis=1)
        best[m] = errs[means.argmin(), m]
        print("depth %g-%g mm: %s, best %s" % (lo, int(hi), " ".join("%.3f" % v for v in means), names[means.argmin()]))
    print("each depth band at its best: %.4f" % best.mean())
    for lo, hi in DEPTHS:
        for tlo, thi in TILTS:
            m = (depth >= lo) & (depth < hi) & (tilt >= tlo) & (tilt < thi)
            if m.any():
                best[m] = errs[errs[:, m].mean(axis=1).argmin(), m]
    print("each depth and tilt band at its best: %.4f" % best.mean())


if __name__ == "__main__":
    main(sys.argv[1:])
