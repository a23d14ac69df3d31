"""The depth's bias on the held-out real edge taps by lateral band and depth band, for both
networks of a `tacsim sim2real` run (its predictions.csv: the first two labels are the lateral
offset and the depth). Printed per network: the mean absolute errors, then a table of the mean
depth error (reading - label, mm) with a row per lateral band -6..-4 ... 4..6 mm and a column
per depth band 3.0-3.5 ... 4.5-5.0 mm (a cell of 3 taps or fewer left blank). Needs numpy.

    python3 docs/sim2real-edge2d/depth_bands.py WORK/predictions.csv
"""
import csv
import sys

import numpy as np


def main(path):
    rows = list(csv.DictReader(open(path)))
    labels = [c[: -len("_sim_trained")] for c in rows[0] if c.endswith("_sim_trained")]
    lateral, depth = labels[0], labels[1]
    col = lambda name: np.array([float(r[name]) for r in rows])  # noqa: E731
    y, z = col(lateral), col(depth)
    for who in ("sim_trained", "real_trained"):
        ey, ez = col(f"{lateral}_{who}") - y, col(f"{depth}_{who}") - z
        print(f"{who}: lateral {np.abs(ey).mean():.3f} mm, depth {np.abs(ez).mean():.3f} mm; depth bias (mm):")
        print("  lateral \\ depth  " + " ".join(f"{a:.1f}-{a + 0.5:.1f}" for a in (3.0, 3.5, 4.0, 4.5)))
        for lo in range(-6, 6, 2):
            cells = []
            for a in (3.0, 3.5, 4.0, 4.5):
                k = (y >= lo) & (y < lo + 2) & (z >= a) & (z < a + 0.5)
                cells.append(f"{ez[k].mean():+7.2f}" if k.sum() > 3 else "       ")
            print(f"  {lo:+d}..{lo + 2:+d} mm      " + " ".join(cells))


if __name__ == "__main__":
    main(sys.argv[1])
