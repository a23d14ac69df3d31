"""Where the pins spread from, across the edge, by lateral offset and depth: real edge taps
against simulated sets (issue 30).

Per tap, the pins are tracked from the undeformed reference (`ring_response.track`; references
as there) and each pin's displacement is projected on the edge normal turned with the yaw
(image angle = ANGLE - yaw: 90 deg for the real taps, 100 deg for a simulated set in the lab's
yaw, -(simulated yaw) - 175.6, both found by the largest mean displacement along the normal).
Pins are binned by their rest coordinate along that normal (6 px bins, -44..44 px) and the mean
projected displacement taken per bin over the taps of a band: the profile runs negative on the
near side and positive on the far side of where the pins spread from, the dent's centre. The
table gives that zero crossing (px from the image centre along the normal) per lateral band
(lab `pose_2`, simulated through lab = OFFSET - simulated x) and depth band (`pose_3`, simulated
through lab = simulated depth + SHIFT), and the crossing's mean move from the shallow band to
the deep one over the lateral bands both hold (negative: towards the image centre). Needs
numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/edge_profile.py ../shared/data/real-tactip-edge2d [SIMSET OFFSET SHIFT]...
"""
import csv
import sys

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from image_change_fit import alike_group  # noqa: E402
from radial_signature import CENTRE, load, pins  # noqa: E402
from ring_response import track  # noqa: E402

BINS = np.arange(-44, 45, 6)
LATERAL = [(-6, -4), (-4, -2), (-2, 0), (0, 2), (2, 4), (4, 6)]
DEPTH = [(3.0, 3.8), (4.3, 5.1)]


def crossing(rest, moves, angles):
    """The outermost zero crossing (px), negative to positive, of the mean profile."""
    total, count = np.zeros(len(BINS) - 1), np.zeros(len(BINS) - 1)
    for moved, angle in zip(moves, angles):
        normal = np.array([np.cos(angle), np.sin(angle)])
        u, v = (rest - CENTRE) @ normal, moved @ normal
        ok = np.isfinite(v)
        b = np.digitize(u[ok], BINS) - 1
        good = (b >= 0) & (b < len(total))
        np.add.at(total, b[good], v[ok][good])
        np.add.at(count, b[good], 1)
    profile = total / np.maximum(count, 1)
    centres = (BINS[:-1] + BINS[1:]) / 2
    up = np.where((profile[:-1] < 0) & (profile[1:] >= 0))[0]
    if not len(up):
        return np.nan
    k = up[-1]
    return centres[k] + (centres[k + 1] - centres[k]) * -profile[k] / (profile[k + 1] - profile[k])


def table(name, rest, moves, lateral, depth, angles):
    print(f"{name}: crossing (px) by lateral band " + " ".join(f"[{a:+d},{b:+d})" for a, b in LATERAL))
    rows = []
    for dlo, dhi in DEPTH:
        cells = []
        for lo, hi in LATERAL:
            m = np.where((lateral >= lo) & (lateral < hi) & (depth >= dlo) & (depth < dhi))[0]
            cells.append(crossing(rest, [moves[i] for i in m], angles[m]) if len(m) else np.nan)
        rows.append(cells)
        print(f"   pose_3 {dlo:.1f}-{dhi:.1f} mm  " + " ".join(f"{c:+7.1f}" if np.isfinite(c) else "     - " for c in cells))
    moved = np.array(rows[-1]) - np.array(rows[0])
    ok = np.isfinite(moved)
    print(f"   deep minus shallow, mean over {ok.sum()} lateral bands: {moved[ok].mean():+.2f} px (- inward)")


def main(real_dir, sims):
    rows = list(csv.DictReader(open(f"{real_dir}/targets.csv")))
    depth = np.array([float(r["pose_3"]) for r in rows])
    lateral = np.array([float(r["pose_2"]) for r in rows])
    yaw = np.array([float(r["pose_6"]) for r in rows])
    images = np.array([load(f"{real_dir}/images/{r['sensor_image']}") for r in rows])
    rest = pins(images[alike_group(images, depth)].mean(0) > 0.5)
    tree = cKDTree(rest)
    table("real", rest, [track(pins(im), rest, tree) for im in images], lateral, depth, np.radians(90.0 - yaw))
    for folder, offset, shift in zip(sims[::3], sims[1::3], sims[2::3]):
        srows = list(csv.DictReader(open(f"{folder}/targets.csv")))
        lateral = float(offset) - np.array([float(r["pose_x"]) for r in srows])
        depth = np.array([float(r["pose_z"]) for r in srows]) + float(shift)
        lab_yaw = -np.array([float(r["pose_Rz"]) for r in srows]) - 175.6
        rest = pins(load(f"{folder}/images/image_0.png"))
        tree = cKDTree(rest)
        moves = [track(pins(load(f"{folder}/images/{r['sensor_image']}")), rest, tree) for r in srows]
        table(folder, rest, moves, lateral, depth, np.radians(100.0 - lab_yaw))


if __name__ == "__main__":
    if len(sys.argv) < 2 or (len(sys.argv) - 2) % 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
