"""Two `cargo xtask real-compare --dump` files' simulated fields against each other, by depth
band: the mean distance between them over the pins both have, as a share of the first's mean
motion, and the least-squares gain of the second onto the first (per recording, then the mean
over the band's recordings). Needs numpy.

    python3 docs/calibration-dome/compare_dumps.py WORK/first.json WORK/second.json
"""

import json
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from error_parts import field  # noqa: E402


def main(first, second):
    a, b = (json.load(open(p))["samples"] for p in (first, second))
    bands = {}
    for x, y in zip(a, b):
        e, t = field(x["sim"]), field(y["sim"])
        ok = ~np.isnan(e).any(axis=1) & ~np.isnan(t).any(axis=1)
        apart = np.linalg.norm(e[ok] - t[ok], axis=1).mean() / np.linalg.norm(e[ok], axis=1).mean()
        gain = (t[ok].ravel() @ e[ok].ravel()) / (e[ok].ravel() @ e[ok].ravel())
        bands.setdefault(min(max(int(x["pose"][2]), 1), 4), []).append((apart, gain))
    for k in sorted(bands):
        v = np.array(bands[k])
        print(f"depth {k}-{k + 1} mm ({len(v)} recordings): {100 * v[:, 0].mean():.1f}% of the motion apart, gain {v[:, 1].mean():.3f}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
