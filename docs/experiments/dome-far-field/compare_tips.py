"""Largest, 99th-percentile and mean distance (mm) between two runs' pin tips.

Reads the files `TIPS_OUT=FILE` makes with `corner-loads.patch` applied (each tap's 331 tips,
x y z, float64 little-endian) and prints the differences:

    python3 docs/experiments/dome-far-field/compare_tips.py EXACT.bin CORNERS.bin
"""

import sys

import numpy as np


def main(a_path, b_path):
    a = np.fromfile(a_path).reshape(-1, 331, 3)
    b = np.fromfile(b_path).reshape(-1, 331, 3)
    d = np.linalg.norm(a - b, axis=2)
    print("%d taps: largest %.4f mm, 99th percentile %.4f mm, mean %.5f mm"
          % (a.shape[0], d.max(), np.percentile(d, 99), d.mean()))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
