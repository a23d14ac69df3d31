"""Yaw readings of the simulator-trained network that fall outside the lab's yaw span.

For each `predictions.csv` of `tacsim sim2real` (edge recordings): the span of the held-out
yaw labels (`pose_Rz`, the shortest arc holding them all), the readings more than MARGIN deg
outside it, their mean error and their share of the whole yaw error.

    python3 docs/sim2real-edge2d/yaw_outside.py WORK/run/predictions.csv [more.csv ...]
"""

import csv
import sys

import numpy as np

MARGIN = 10.0  # deg beyond the lab's span before a reading counts as outside


def span(deg):
    """Start and width (deg) of the shortest arc holding every angle."""
    a = np.sort((np.asarray(deg) + 180.0) % 360.0 - 180.0)
    gaps = np.diff(np.concatenate([a, [a[0] + 360.0]]))
    k = int(np.argmax(gaps))
    start = a[(k + 1) % len(a)]
    return start, 360.0 - gaps[k]


for path in sys.argv[1:]:
    rows = list(csv.DictReader(open(path)))
    label = np.array([float(r["pose_Rz"]) for r in rows])
    read = np.array([float(r["pose_Rz_sim_trained"]) for r in rows])
    err = np.abs((read - label + 180.0) % 360.0 - 180.0)
    lo, width = span(label)
    beyond = (read - (lo - MARGIN)) % 360.0 > width + 2.0 * MARGIN
    mean = f"{err[beyond].mean():.1f} deg" if beyond.any() else "-"
    print(
        f"{path}: lab span {lo:.1f} + {width:.1f} deg; {beyond.sum()} of {len(rows)} readings more than "
        f"{MARGIN:.0f} deg outside, mean error {mean}, {err[beyond].sum() / err.sum():.1%} of the yaw error "
        f"(yaw error {err.mean():.2f} deg)"
    )
