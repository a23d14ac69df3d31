"""Is the simulator-trained network's error on the held-out real edge taps a rig effect that
turns with the yaw (issue 30)? A sensor axis off the robot's yaw axis, or a tilted tool, moves
the contact by a vector that turns with the yaw: the lateral error would then follow
a cos(yaw) + b sin(yaw). From one or more `tacsim sim2real` runs' predictions.csv (lateral
`pose_y`, depth `pose_z`, yaw `pose_Rz`, as the lab's labels are renamed there), per run and
network: the mean absolute error, after the best straight line in lateral and depth, and after
that line plus the two yaw terms (with their amplitude); the lateral and yaw bias by 20 deg
yaw band. With several runs (training seeds of one set), the error of their mean reading too.
A diagnosis on held-out labels, not a fit. Needs numpy.

    python3 docs/sim2real-edge2d/yaw_terms.py RUN/predictions.csv [RUN2/predictions.csv ...]
"""
import csv
import sys

import numpy as np


def wrap(deg):
    return (deg + 180) % 360 - 180


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
