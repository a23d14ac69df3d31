"""Is the lab's sensor tilted on its mount (issue 85)? A sensor whose axis leans off the robot's
yaw axis meets the edge with a tilt that turns with the yaw: in the edge's frame its taps then
change with the edge's angle in the image by one cycle a turn, which an upright sensor's do
not (its pin lattice repeats every 60 deg). Each tap's pin motion is tracked and turned into
the edge's frame as in field_knn.py (a 12 x 12 grid of 8 px cells, the motion across and along
the edge); from each field the mean field of its domain's taps of the same lateral and depth
band (1 mm by 0.5 mm) is taken away, and what is left is fitted by `C cos(a) + S sin(a)` in
the edge normal's image angle `a`: the pair (C, S) is the domain's one-cycle signature. The
lab's (fitting taps only, `is_held_out`) is then written as a sum of the signatures of
simulated sets tilted by a known angle about the sensor's `x` and `y` axes (recipe
`rx_deg = [T, T]` or `ry_deg = [T, T]`, the pose's tilts in the sensor's own frame, so they
turn with the yaw), less an upright set's: the tilt (deg) that best gives the lab's signature
and the share of it that tilt explains. Printed beside: how the lab's two halves (alternate
taps) agree, and how alike the lab's and the upright set's signatures are (cosine). Each
further set is scored alone against what the upright set leaves of the lab's signature (its
change from the upright set: size, cosine, best scale and the share that explains; for
instance a set with the pin field shifted, `[randomise] camera_shift_px = [1.0, 1.0]`).
Simulated sets: image angle `yaw - 84.4` deg, the lab's `90 - yaw` (field_knn.py's). Needs
numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/tilt_screen.py ../shared/data/real-tactip-edge2d-full UPRIGHT RX_SET RY_SET T [SET...]
"""
import csv
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from field_knn import lab_fields, sim_fields  # noqa: E402
from image_change_fit import is_held_out  # noqa: E402


def signature(f, lateral, depth, angle):
    """The one-cycle signature (C, S) of fields `f` after each lateral and depth band's mean."""
    li = np.floor(lateral).astype(int)
    di = np.floor(depth / 0.5).astype(int)
    band = li * 100 + di
    rest = f.copy()
    for b in np.unique(band):
        m = band == b
        rest[m] -= f[m].mean(0)
    x = np.c_[np.cos(angle), np.sin(angle)]
    coef, *_ = np.linalg.lstsq(x, rest, rcond=None)
    return coef.ravel(), np.sqrt((rest**2).sum(1).mean())


def sim_set(folder):
    rows, f, angle = sim_fields(folder)
    lateral = -np.array([float(r["pose_x"]) for r in rows])
    depth = np.array([float(r["pose_z"]) for r in rows])
    return signature(f, lateral, depth, angle)


def cosine(a, b):
    return a @ b / np.linalg.norm(a) / np.linalg.norm(b)


def main(real_dir, upright, rx_set, ry_set, t, *others):
    t = float(t)
    rows = [r for r in csv.DictReader(open(f"{real_dir}/targets.csv")) if not is_held_out(r["sensor_image"])]
    angle = np.radians(90.0 - np.array([float(r["pose_6"]) for r in rows]))
    real, lateral, depth = lab_fields(real_dir, lambda name: not is_held_out(name))
    lab, lab_rest = signature(real, lateral, depth, angle)
    half = np.arange(len(lateral)) % 2 == 0
    one, two = (signature(real[h], lateral[h], depth[h], angle[h])[0] for h in (half, ~half))
    base, base_rest = sim_set(upright)
    rx, _ = sim_set(rx_set)
    ry, _ = sim_set(ry_set)
    per_deg = np.c_[(rx - base) / t, (ry - base) / t]
    tilt, *_ = np.linalg.lstsq(per_deg, lab - base, rcond=None)
    left = lab - base - per_deg @ tilt
    print(f"{real_dir}: {len(real)} fitting taps; rms field after the bands' means: lab {lab_rest:.3f} px, "
          f"upright set {base_rest:.3f} px")
    print(f"one-cycle signature's norm (px): lab {np.linalg.norm(lab):.3f}, upright set {np.linalg.norm(base):.3f}, "
          f"per deg about x {np.linalg.norm(per_deg[:, 0]):.3f}, about y {np.linalg.norm(per_deg[:, 1]):.3f}")
    print(f"the lab's halves: cosine {cosine(one, two):.2f}, half their difference {np.linalg.norm(one - two) / 2:.3f} px; "
          f"the lab's against the upright set's: cosine {cosine(lab, base):.2f}, difference {np.linalg.norm(lab - base):.3f} px")
    explained = 1 - (left @ left) / ((lab - base) @ (lab - base))
    print(f"tilt that best gives the lab's signature: rx {tilt[0]:+.2f} deg, ry {tilt[1]:+.2f} deg; "
          f"share of the lab's signature (less the upright set's) it explains: {explained:.2f}")
    for folder in others:
        change = sim_set(folder)[0] - base
        rest = lab - base
        k = change @ rest / (change @ change)
        share = 1 - np.linalg.norm(rest - k * change) ** 2 / np.linalg.norm(rest) ** 2
        print(f"{folder}: change {np.linalg.norm(change):.3f} px, cosine with the lab's rest {cosine(change, rest):+.2f}, "
              f"best scale {k:+.3f}, explains {share:.2f}")


if __name__ == "__main__":
    if len(sys.argv) < 6:
        sys.exit(__doc__)
    main(*sys.argv[1:])
