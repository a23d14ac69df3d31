"""A reader in the edge's frame for the whole-turn edge taps (issue 85): does a better reader of
the simulated pin motion read the lab's lateral offset within 0.5 mm, the yaw given?
Each tap's pin-motion field as field_knn.py makes it (tracked from its domain's undeformed
reference, turned into the edge's frame by its yaw label, 12 x 12 cells of 8 px), read by
kernel ridge regression (Gaussian kernel, width from the lab's fields) trained on a simulated
set's fields and labels, and, beside it, the same reader trained on the lab's own fitting part
(the held-out fifth, `is_held_out`, is never fitted). The simulated reader's lateral and depth
go into the lab's frame by a sign and an offset fitted on the fitting part (lab lateral =
offset - simulated x, lab depth = simulated depth + shift; the offsets the medians), as
`tacsim sim2real` maps its networks; printed: the held-out mean errors (mm). "matched": each
simulated cell's motion first moved to the lab's fitting part's mean and spread per cell (the
lab's labels unused). With `--yaw RUN` (a `tacsim sim2real` run's report folder: its
predictions.csv and fitting.csv) every lab tap is turned by that run's simulator-trained yaw
reading instead of its label, so that the yaw is read first and no label but the map's
offsets is used: a two-stage reader. Needs numpy, scipy and pillow.
    python3 docs/sim2real-edge2d/field_reader.py ../shared/data/real-tactip-edge2d-full [--yaw RUN] SIMSET...
"""
import csv
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from field_knn import fields, lab_fields  # noqa: E402
from image_change_fit import is_held_out  # noqa: E402
from radial_signature import load  # noqa: E402

WIDTH = 0.3  # the kernel's exponent times the median squared norm of the lab's fields
RIDGE_SIM, RIDGE_LAB = 0.1, 0.01


def kernel(a, b, gamma):
    d = (a * a).sum(1)[:, None] + (b * b).sum(1)[None] - 2 * a @ b.T
    return np.exp(-gamma * np.maximum(d, 0))


def ridge(x, y, z, gamma, lam):
    """Kernel ridge regression of `y` on `x`, read at `z`."""
    return kernel(z, x, gamma) @ np.linalg.solve(kernel(x, x, gamma) + lam * np.eye(len(x)), y)


def matched(sim, lab):
    """Each cell of the simulated fields moved to the lab's mean and spread for that cell."""
    return (sim - sim.mean(0)) / (sim.std(0) + 1e-3) * lab.std(0) + lab.mean(0)


def errors(read, lateral, depth):
    return f"lateral {np.abs(read[:, 0] - lateral).mean():.3f} mm, depth {np.abs(read[:, 1] - depth).mean():.3f} mm"


def main(real_dir, sets):
    names = [r["sensor_image"] for r in csv.DictReader(open(f"{real_dir}/targets.csv"))]
    yaws = None
    if sets[:1] == ["--yaw"]:
        rows = [r for part in ("predictions", "fitting") for r in csv.DictReader(open(f"{sets[1]}/{part}.csv"))]
        yaws = {r["image"]: float(r["pose_Rz_sim_trained"]) for r in rows}
        print(f"every lab tap turned by the yaw read in {sets[1]}")
        sets = sets[2:]
    lab, lateral, depth = lab_fields(real_dir, yaws=yaws)
    held = np.array([is_held_out(n) for n in names])
    fit = ~held
    gamma = WIDTH / np.median((lab[fit] ** 2).sum(1))
    print(f"{real_dir}: {fit.sum()} fitting, {held.sum()} held-out taps")
    own = ridge(lab[fit], np.c_[lateral[fit], depth[fit]], lab[held], gamma, RIDGE_LAB)
    print(f"   trained on the lab's fitting part: {errors(own, lateral[held], depth[held])}")
    for folder in sets:
        rows = list(csv.DictReader(open(f"{folder}/targets.csv")))
        yaw = np.array([float(r["pose_Rz"]) for r in rows])
        sim = fields(folder, [r["sensor_image"] for r in rows], np.radians(yaw - 84.4), load(f"{folder}/images/image_0.png"))
        labels = np.c_[[float(r["pose_x"]) for r in rows], [float(r["pose_z"]) for r in rows]]
        for name, train in [("as simulated", sim), ("matched", matched(sim, lab[fit]))]:
            read = ridge(train, labels, lab, gamma, RIDGE_SIM)
            offset = np.median(lateral[fit] + read[fit, 0])
            shift = np.median(depth[fit] - read[fit, 1])
            mapped = np.c_[offset - read[held, 0], read[held, 1] + shift]
            print(f"   {folder} ({len(rows)} taps), {name}: {errors(mapped, lateral[held], depth[held])} "
                  f"(offset {offset:+.2f}, shift {shift:+.2f} mm)")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
