"""Does the lab sensor's axis offset belong in the edge map? Judged on the fitting taps alone.

From a `tacsim sim2real` run's fitting.csv (made without `--axis-offset`: the simulator-trained
network's readings of the lab's fitting taps through the plain map, with their labels), five
folds of the fitting taps (a seeded shuffle): on each, the lateral's error after an offset,
and after an offset plus `a cos + b sin` of the yaw read, each fitted by least squares on the
other four folds. Prints both mean absolute errors and the terms fitted on every fitting tap
(amplitude and phase). The held-out taps are not read. Needs numpy.

    python3 docs/sim2real-edge2d/axis_offset_cv.py RUN/fitting.csv [RUN2/fitting.csv ...]
"""
import csv
import sys

import numpy as np

FOLDS = 5


def main(paths):
    for path in paths:
        rows = list(csv.DictReader(open(path)))
        col = lambda k: np.array([float(r[k]) for r in rows])  # noqa: E731
        err = col("pose_y_sim_trained") - col("pose_y")
        th = np.radians(col("pose_Rz_sim_trained"))
        designs = {"offset": np.ones((len(err), 1)), "offset + yaw terms": np.c_[np.ones(len(err)), np.cos(th), np.sin(th)]}
        folds = np.random.default_rng(0).permutation(len(err)) % FOLDS
        scores = {}
        for name, a in designs.items():
            left = np.zeros_like(err)
            for f in range(FOLDS):
                fit, held = folds != f, folds == f
                left[held] = err[held] - a[held] @ np.linalg.lstsq(a[fit], err[fit], rcond=None)[0]
            scores[name] = np.abs(left).mean()
        c = np.linalg.lstsq(designs["offset + yaw terms"], err, rcond=None)[0]
        print(f"{path}: {len(err)} fitting taps, lateral after {FOLDS}-fold fits: offset {scores['offset']:.3f} mm, "
              f"offset + yaw terms {scores['offset + yaw terms']:.3f} mm; terms on every tap {c[1]:+.3f} cos {c[2]:+.3f} sin "
              f"(amplitude {np.hypot(c[1], c[2]):.3f} mm, phase {np.degrees(np.arctan2(c[2], c[1])):.0f} deg)")


if __name__ == "__main__":
    main(sys.argv[1:])
