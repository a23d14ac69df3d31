"""Where the yaw error of a `tacsim sim2real` run on the edge taps lives (issue 30): the mean
absolute yaw error (deg, wrapped) of both networks by lateral band (-6..-4 ... 4..6 mm) and
depth band (`pose_3` 3.0-3.5 ... 4.5-5.0 mm), from the run's predictions.csv (the first
`_sim_trained` label is the lateral, the second the depth, the last the yaw). Each cell:
sim-trained / real-trained (taps). Needs numpy.

    python3 docs/sim2real-edge2d/yaw_cells.py WORK/predictions.csv
"""
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from predictions import band_table, depth_header, read  # noqa: E402


def main(path):
    labels, col, _ = read(path)
    lateral, depth, yaw = labels[0], labels[1], labels[-1]
    y, z, truth = col(lateral), col(depth), col(yaw)
    err = {k: np.abs((col(f"{yaw}_{k}_trained") - truth + 180) % 360 - 180) for k in ("sim", "real")}
    print(f"{path}: yaw ({yaw}) error sim-trained {err['sim'].mean():.2f}, real-trained {err['real'].mean():.2f} deg")
    print("lateral band \\ depth band | " + " | ".join(depth_header()))
    cell = lambda m: f"{err['sim'][m].mean():5.1f} / {err['real'][m].mean():4.1f} ({m.sum()})" if m.any() else "-"  # noqa: E731
    for name, cells in band_table(y, z, cell):
        print(f"{name} | " + " | ".join(cells))
    total = err["sim"].sum()
    share = lambda m: err["sim"][m].sum() / total  # noqa: E731
    print(f"share of the sim-trained yaw error from lateral < -4 mm: {share(y < -4):.0%}; from lateral < -4 mm and pose_3 < 3.5 mm: {share((y < -4) & (z < 3.5)):.0%}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
