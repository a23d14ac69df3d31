"""Is the simulator-trained network's error on the held-out real edge taps a rig effect that
turns with the yaw (issue 30)? A sensor axis off the robot's yaw axis, or a tilted tool, moves
the contact by a vector that turns with the yaw: the lateral error would then follow
a cos(yaw) + b sin(yaw). From one or more `tacsim sim2real` runs' predictions.csv (lateral
`pose_y`, depth `pose_z`, yaw `pose_Rz`, as the lab's labels are renamed there), per run and
network: the mean absolute error, after the best straight line in lateral and depth, and after
that line plus the two yaw terms (with their amplitude); the lateral and yaw bias by 20 deg
yaw band. With several runs (training seeds of one set), the error of their mean reading too.
Where a run's `fitting.csv` lies beside its predictions, the lateral's offset and yaw terms
fitted there are scored on the held-out taps. Otherwise a diagnosis on held-out labels, not a
fit. Needs numpy.

    python3 docs/sim2real-edge2d/yaw_terms.py RUN/predictions.csv [RUN2/predictions.csv ...]
"""
import csv
import os
import sys

import numpy as np


def wrap(deg):
    return (deg + 180) % 360 - 180


def held_out_terms(fitting, rows):
    """A rig that turns with the yaw taken into the label map: the simulator-trained lateral
    reading's offset, and with it `a cos + b sin` of the yaw it read, fitted on the fitting
    part's readings (`fitting.csv` beside `predictions.csv`, the lab's labels there) and scored
    on the held-out taps, as a lab with those labels could map its readings."""
    fit = list(csv.DictReader(open(fitting)))
    col = lambda r, k: np.array([float(x[k]) for x in r])  # noqa: E731

    def terms(r):
        th = np.radians(col(r, "pose_Rz_sim_trained"))
        return np.c_[np.ones(len(r)), np.cos(th), np.sin(th)]

    err_fit = col(fit, "pose_y_sim_trained") - col(fit, "pose_y")
    err = col(rows, "pose_y_sim_trained") - col(rows, "pose_y")
    coef = np.linalg.lstsq(terms(fit), err_fit, rcond=None)[0]
    print(f"  sim-trained lateral on the held-out taps: {np.abs(err).mean():.3f} mm; less the fitting part's mean "
          f"error {np.abs(err - err_fit.mean()).mean():.3f}; less its offset and yaw terms {np.abs(err - terms(rows) @ coef).mean():.3f} "
          f"(amplitude {np.hypot(coef[1], coef[2]):.2f} mm, the yaw read)")


def main(paths):
    runs = [list(csv.DictReader(open(p))) for p in paths]
    for path, rows in zip(paths, runs):
        col = lambda k: np.array([float(r[k]) for r in rows])  # noqa: E731
        y, z, yaw = col("pose_y"), col("pose_z"), col("pose_Rz")
        th = np.radians(yaw)
        line = np.c_[np.ones_like(y), y, z]
        turning = np.c_[line, np.cos(th), np.sin(th)]
        print(path)
        for who in ("sim", "real"):
            for name, err in (
                ("lateral (mm)", col(f"pose_y_{who}_trained") - y),
                ("yaw (deg)", wrap(col(f"pose_Rz_{who}_trained") - yaw)),
            ):
                after_line = err - line @ np.linalg.lstsq(line, err, rcond=None)[0]
                coef = np.linalg.lstsq(turning, err, rcond=None)[0]
                after_yaw = err - turning @ coef
                print(
                    f"  {who}-trained {name:12s} {np.abs(err).mean():6.2f} | after the line in lateral and depth "
                    f"{np.abs(after_line).mean():5.2f} | with a cos + b sin of the yaw {np.abs(after_yaw).mean():5.2f} "
                    f"(amplitude {np.hypot(coef[3], coef[4]):.2f})"
                )
        fitting = os.path.join(os.path.dirname(path), "fitting.csv")
        if os.path.isfile(fitting):
            held_out_terms(fitting, rows)
        bands = [(a, (yaw >= a) & (yaw < a + 20)) for a in range(-180, 180, 20)]
        lateral = col("pose_y_sim_trained") - y
        turn = wrap(col("pose_Rz_sim_trained") - yaw)
        print("  sim-trained bias by yaw band, lateral mm / yaw deg: " + ", ".join(
            f"[{a},{a + 20}) {lateral[m].mean():+.2f} / {turn[m].mean():+.1f} ({m.sum()})" for a, m in bands if m.sum()))
    if len(runs) > 1:
        names = [[r["image"] for r in rows] for rows in runs]
        assert all(n == names[0] for n in names), "the runs must hold the same held-out images"
        col = lambda rows, k: np.array([float(r[k]) for r in rows])  # noqa: E731
        y, yaw = col(runs[0], "pose_y"), col(runs[0], "pose_Rz")
        lateral = np.mean([col(rows, "pose_y_sim_trained") for rows in runs], 0)
        angles = np.radians([col(rows, "pose_Rz_sim_trained") for rows in runs])
        turn = np.degrees(np.arctan2(np.sin(angles).mean(0), np.cos(angles).mean(0)))
        print(f"mean reading of the {len(runs)} runs: lateral {np.abs(lateral - y).mean():.2f} mm, "
              f"yaw {np.abs(wrap(turn - yaw)).mean():.2f} deg")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
