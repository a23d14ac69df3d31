"""The simulator-trained network's lateral error on the held-out real taps, split by depth and
lateral band (issue 30), from a `tacsim sim2real` run's predictions.csv (the first two labels
with a `_sim_trained` reading: lateral, then depth). Printed: the mean absolute error, the
slope of the readings against the labels (the gain), the mean error (bias) per `pose_3` band
3.0-3.5 ... 4.5-5.0 mm and per lateral band -6..-4 ... 4..6 mm, and the error left after the
best straight line in the lateral and depth labels (a diagnosis on held-out labels, not a fit).
Needs numpy.

    python3 docs/sim2real-edge2d/lateral_bias.py WORK/predictions.csv
"""
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from predictions import DEPTH_BANDS, LATERAL_BANDS, read  # noqa: E402


def main(path):
    labels, col, _ = read(path)
    lateral, depth = labels[0], labels[1]
    y, z, reading = col(lateral), col(depth), col(lateral + "_sim_trained")
    error = reading - y
    print(f"{path}: {len(y)} taps, lateral ({lateral}) error {np.abs(error).mean():.2f} mm, gain {np.polyfit(y, reading, 1)[0]:.2f}")
    print("bias by depth band (mm):   " + " ".join(f"{error[(z >= a) & (z < a + 0.5)].mean():+.2f}" for a in DEPTH_BANDS))
    print("bias by lateral band (mm): " + " ".join(f"{error[(y >= a) & (y < a + 2)].mean():+.2f}" for a in LATERAL_BANDS))
    design = np.c_[y, z, np.ones_like(y)]
    coef, *_ = np.linalg.lstsq(design, error, rcond=None)
    print(f"after the best line in lateral and depth: {np.abs(error - design @ coef).mean():.2f} mm")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
