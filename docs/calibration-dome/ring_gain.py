"""The simulated pin motion's gain against the lab's by the pin's distance from the image's
centre, by depth band.

Reads a `cargo xtask real-compare --dump FILE` of the surface recordings. The reference pins
are cut into six bands of equal count by their distance from the reference's mean position;
per band and depth band (`error_parts.py`'s), over the recordings of all tilts, tilted under
8 deg and tilted over 15 deg: the least-squares gain `|g|` of the simulated motion onto the
real one (`real ~ g sim`, the pins' motion as complex numbers), and the ratio of the mean
real motion to the mean simulated one. Over 1: the lab's pins in that band move more.

    python3 docs/calibration-dome/ring_gain.py WORK/dump.json
"""

import json
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from error_parts import DEPTHS, field  # noqa: E402

BANDS = 6
SUBSETS = (("all", lambda t: True), ("tilt < 8", lambda t: t < 8), ("tilt > 15", lambda t: t > 15))


def main(path):
    dump = json.load(open(path))
    ref = np.array(dump["reference"], dtype=float)
    r = np.hypot(*(ref - ref.mean(axis=0)).T)
    edges = np.quantile(r, np.linspace(0, 1, BANDS + 1))
    band = [(r >= lo) & (r <= hi) for lo, hi in zip(edges[:-1], edges[1:])]
    print("bands of distance from the centre (px):", " ".join("%.0f-%.0f" % e for e in zip(edges[:-1], edges[1:])))
    print("subset     depth (mm)  n    gain |g| by band                  mean real / mean simulated")
    for name, keep in SUBSETS:
        for lo, hi in DEPTHS:
            num, den = np.zeros(BANDS, complex), np.zeros(BANDS)
            real_sum, sim_sum, n = np.zeros(BANDS), np.zeros(BANDS), 0
            for s in dump["samples"]:
                pose = s["pose"]
                if not keep(np.hypot(pose[3], pose[4])) or not lo <= pose[2] < hi:
                    continue
                n += 1
                real, sim = field(s["real"]), field(s["sim"])
                ok = ~np.isnan(real).any(axis=1) & ~np.isnan(sim).any(axis=1)
                zr, zs = real[:, 0] + 1j * real[:, 1], sim[:, 0] + 1j * sim[:, 1]
                for b, m in enumerate(band):
                    m = m & ok
                    num[b] += (np.conj(zs[m]) * zr[m]).sum()
                    den[b] += (np.abs(zs[m]) ** 2).sum()
                    real_sum[b] += np.abs(zr[m]).sum()
                    sim_sum[b] += np.abs(zs[m]).sum()
            print("%-10s %g-%g %5d    %s    %s" % (name, lo, int(hi), n, " ".join("%.2f" % g for g in np.abs(num / den)),
                                                  " ".join("%.2f" % g for g in real_sum / sim_sum)))


if __name__ == "__main__":
    main(sys.argv[1])
