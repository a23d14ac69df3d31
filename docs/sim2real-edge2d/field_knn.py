"""A screen for a candidate body before a `tacsim sim2real` run (issue 85): how the lab's edge
taps read against a simulated set by their pin displacement fields alone, nearest neighbours in
place of the pose network.
Each tap's pins are tracked from its domain's undeformed reference (as in ring_response.py: the
real taps' consensus of the 30 most alike of the shallowest half, taps that touch nothing; a
simulated set's image_0.png), turned into the edge's frame by the yaw label (image angle
90 - yaw for the lab's taps, simulated yaw - 84.4 deg for a set: edge_profile.py's angles) and
averaged on a 12 x 12 grid of 8 px cells (the motion across and along the edge, px at 128).
Every real tap of the lab's fitting part (not the held-out fifth, `is_held_out`) reads the mean
labels of its K nearest simulated fields (Euclidean), through lab lateral = OFFSET - simulated x
and lab depth = simulated depth + SHIFT. Printed: the lateral reading's mean error, its bias per
depth band and the slope of that bias in the depth (mm per mm: the network's on the dome was
1.74, the half-space's 1.53; docs/experiments/sim2real.md), the scatter about each band's line,
and the depth reading's gain. The constant bias is the map's offset: the reading's error
without it is the screen's figure (the label maps were fitted on the networks' readings of the
pin images, whose offset the lattice's mismatch moves). `real` in place of a set reads the fitting part against itself
(leave-one-out): the floor of the screen. Needs numpy, pillow, scipy.
    python3 docs/sim2real-edge2d/field_knn.py ../shared/data/real-tactip-edge2d-full [real | SIMSET OFFSET SHIFT]...
"""
import csv
import sys

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from image_change_fit import alike_group, is_held_out  # noqa: E402
from radial_signature import CENTRE, load, pins  # noqa: E402
from ring_response import track  # noqa: E402

K = 7
CELL = 8.0
CELLS = 12
BANDS = [(3.0, 3.5), (3.5, 4.0), (4.0, 4.5), (4.5, 5.01)]


def field(rest, moved, angle):
    """The displacement across and along the edge averaged per grid cell (zero where no pin)."""
    n = np.array([np.cos(angle), np.sin(angle)])
    t = np.array([-n[1], n[0]])
    p = rest - CENTRE
    u, v = p @ n, p @ t
    ok = np.isfinite(moved[:, 0])
    i = np.floor(u / CELL + CELLS / 2).astype(int)
    j = np.floor(v / CELL + CELLS / 2).astype(int)
    good = ok & (i >= 0) & (i < CELLS) & (j >= 0) & (j < CELLS)
    cell = i[good] * CELLS + j[good]
    total = np.zeros((2, CELLS * CELLS))
    count = np.zeros(CELLS * CELLS)
    np.add.at(total[0], cell, moved[good] @ n)
    np.add.at(total[1], cell, moved[good] @ t)
    np.add.at(count, cell, 1)
    return (total / np.maximum(count, 1)).ravel()


def fields(folder, names, angles, reference):
    rest = pins(reference)
    tree = cKDTree(rest)
    return np.array([field(rest, track(pins(load(f"{folder}/images/{n}")), rest, tree), a) for n, a in zip(names, angles)])


def report(name, lateral, depth, read_lateral, read_depth):
    err = read_lateral - lateral
    print(f"{name}: lateral error {np.abs(err).mean():.2f} mm (bias {err.mean():+.2f}; "
          f"{np.abs(err - err.mean()).mean():.2f} without it), "
          f"depth error {np.abs(read_depth - depth).mean():.2f} mm, depth gain {np.polyfit(depth, read_depth, 1)[0]:.2f}")
    slope = np.polyfit(depth, err, 1)[0]
    cells = []
    for lo, hi in BANDS:
        m = (depth >= lo) & (depth < hi)
        b, a = np.polyfit(lateral[m], read_lateral[m], 1)
        scatter = np.abs(read_lateral[m] - a - b * lateral[m]).mean()
        cells.append(f"{lo:.1f}-{min(hi, 5.0):.1f} mm: bias {err[m].mean():+.2f}, scatter {scatter:.2f}")
    print(f"   lateral bias against depth: {slope:+.2f} mm per mm; " + "; ".join(cells))


def sim_fields(folder):
    """A simulated set's rows, motion fields in the edge's frame (image angle `yaw - 84.4` deg)
    and those angles (rad)."""
    rows = list(csv.DictReader(open(f"{folder}/targets.csv")))
    angle = np.radians(np.array([float(r["pose_Rz"]) for r in rows]) - 84.4)
    return rows, fields(folder, [r["sensor_image"] for r in rows], angle, load(f"{folder}/images/image_0.png")), angle


def lab_fields(real_dir, keep=lambda name: True, yaws=None):
    """The lab's taps whose image name `keep` accepts: their motion fields (tracked from the
    consensus of these taps), lateral labels and depths. Each field is turned into the edge's
    frame by its yaw label, or by `yaws[name]` (deg) where `yaws` names the image."""
    rows = [r for r in csv.DictReader(open(f"{real_dir}/targets.csv")) if keep(r["sensor_image"])]
    names = [r["sensor_image"] for r in rows]
    depth = np.array([float(r["pose_3"]) for r in rows])
    lateral = np.array([float(r["pose_2"]) for r in rows])
    yaw = np.array([float(r["pose_6"]) for r in rows])
    images = np.array([load(f"{real_dir}/images/{n}") for n in names])
    reference = images[alike_group(images, depth)].mean(0) > 0.5
    if yaws is not None:
        yaw = np.array([yaws.get(n, y) for n, y in zip(names, yaw)])
    return fields(real_dir, names, np.radians(90.0 - yaw), reference), lateral, depth


def main(real_dir, args):
    real, lateral, depth = lab_fields(real_dir, lambda name: not is_held_out(name))
    print(f"{real_dir}: {len(real)} fitting taps, K = {K}")
    while args:
        if args[0] == "real":
            args = args[1:]
            _, near = cKDTree(real).query(real, K + 1)
            near = near[:, 1:]
            report("real (leave-one-out)", lateral, depth, lateral[near].mean(1), depth[near].mean(1))
            continue
        folder, offset, shift, args = args[0], float(args[1]), float(args[2]), args[3:]
        srows, sim, _ = sim_fields(folder)
        sim_lateral = offset - np.array([float(r["pose_x"]) for r in srows])
        sim_depth = np.array([float(r["pose_z"]) for r in srows]) + shift
        _, near = cKDTree(sim).query(real, K)
        report(folder, lateral, depth, sim_lateral[near].mean(1), sim_depth[near].mean(1))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
