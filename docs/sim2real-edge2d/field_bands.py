"""Where a simulated set's pin motion parts from the lab's, band by band (issue 85): the mean
motion field of the lab's edge taps in each band of lateral position and depth against the
simulated taps' in the same band, both in the edge's frame (field_knn.py's 12 x 12 grid of 8 px
cells, turned by each tap's yaw label).

Bands: lab lateral -5..-3, -3..-1, -1..1, 1..3, 3..5 mm (negative: the sensor off the material,
positive: onto it) by depth 3.0-3.6, 3.6-4.3, 4.3-5.1 mm. The simulated labels go into the
lab's frame through lab lateral = OFFSET - simulated x (OFFSET searched over -1..1 mm in 0.25
mm steps for the least summed squared distance) and lab depth = simulated depth - 0.05 mm
(field_knn.py's shift). Printed per set: the offset, the summed squared distance of the band
means (px^2) and their mean relative distance (|sim - real| / |real|); per band its relative
distance and the lateral, in 0.5 mm steps, whose simulated mean field (taps within 0.5 mm of
it, the same depth band) is nearest the lab's band mean, minus the band's centre (0: the
simulated taps at the lab's lateral look most like the lab's; -1.5: the lab's taps look like
the simulated ones 1.5 mm nearer the material's edge). Every tap of the lab folder is used.
Each set's fields are cached beside it (SIMSET.fields.npz). Needs numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/field_bands.py ../shared/data/real-tactip-edge2d-full SIMSET...
"""
import csv
import os
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from field_knn import fields, lab_fields  # noqa: E402
from radial_signature import load  # noqa: E402

LATERAL = [(-5, -3), (-3, -1), (-1, 1), (1, 3), (3, 5)]
DEPTH = [(3.0, 3.6), (3.6, 4.3), (4.3, 5.1)]
BANDS = [(lat, dep) for lat in LATERAL for dep in DEPTH]
SHIFT = -0.05
OFFSETS = np.arange(-1.0, 1.001, 0.25)


def sim_fields(folder):
    rows = list(csv.DictReader(open(f"{folder}/targets.csv")))
    cache = folder.rstrip("/") + ".fields.npz"
    if os.path.exists(cache):
        motion = np.load(cache)["fields"]
    else:
        yaw = np.array([float(r["pose_Rz"]) for r in rows])
        names = [r["sensor_image"] for r in rows]
        motion = fields(folder, names, np.radians(yaw - 84.4), load(f"{folder}/images/image_0.png"))
        np.savez(cache, fields=motion)
    x = np.array([float(r["pose_x"]) for r in rows])
    return motion, x, np.array([float(r["pose_z"]) for r in rows]) + SHIFT


def in_band(lateral, depth, band):
    (l0, l1), (d0, d1) = band
    return (lateral >= l0) & (lateral < l1) & (depth >= d0) & (depth < d1)


def compare(real, sim, offset):
    """Summed squared distance and per-band relative distance of the band means."""
    (r, lat, dep), (s, x, sdep) = real, sim
    total, relative = 0.0, []
    for band in BANDS:
        a, b = r[in_band(lat, dep, band)].mean(0), s[in_band(offset - x, sdep, band)].mean(0)
        total += float(((b - a) ** 2).sum())
        relative.append(np.linalg.norm(b - a) / np.linalg.norm(a))
    return total, relative


def nearest_lateral(real, sim, offset, band):
    (r, lat, dep), (s, x, sdep) = real, sim
    target = r[in_band(lat, dep, band)].mean(0)
    d0, d1 = band[1]
    best = (np.inf, 0.0)
    for c in np.arange(-6.0, 6.001, 0.5):
        m = (np.abs(offset - x - c) < 0.5) & (sdep >= d0) & (sdep < d1)
        if m.sum() > 3:
            best = min(best, (float(np.linalg.norm(s[m].mean(0) - target)), c))
    return best[1] - 0.5 * sum(band[0])


def main(real_dir, sets):
    real = lab_fields(real_dir)
    print(f"{real_dir}: {len(real[1])} taps; bands: lateral {LATERAL} mm x depth {DEPTH} mm")
    for folder in sets:
        sim = sim_fields(folder)
        offset = min(OFFSETS, key=lambda o: compare(real, sim, o)[0])
        total, relative = compare(real, sim, offset)
        shifts = [nearest_lateral(real, sim, offset, band) for band in BANDS]
        print(f"{folder}: offset {offset:+.2f} mm, summed distance {total:.1f} px^2, mean relative {np.mean(relative):.3f}")
        for lat, k in zip(LATERAL, range(0, len(BANDS), len(DEPTH))):
            cells = ", ".join(f"{relative[k + j]:.2f} ({shifts[k + j]:+.1f} mm)" for j in range(len(DEPTH)))
            print(f"   lateral {lat[0]:+d}..{lat[1]:+d} mm, shallow / mid / deep: {cells}")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
