"""How far a contact beside the pins reaches them, real edge taps against simulated ones, at
the lateral offset the sim2real label map found (issue 30). A few seconds per simulated set,
so a candidate sensor is screened before a 15-minute `tacsim sim2real` run.

Per tap, the pins (blobs as in radial_signature.py) are tracked from the undeformed
reference's (`track`: within 2 px of where their matched neighbours' motion puts them; the
reference of the real taps is the majority of the 30 most alike of the shallowest half, taps
that touch nothing, of a simulated set its image_0.png), and four features are taken: the mean radial
displacement (px, + outward) of the pins 4-16 px from the image centre (inner), 16-28 px (mid)
and 28-44 px (outer), and ten times the share of pin-field pixels that changed. Each set's
features are interpolated at every real tap's labels (Gaussian kernel, 0.4 mm lateral, 0.1 mm
depth) through lab lateral = OFFSET - simulated x and lab depth = simulated depth + SHIFT;
OFFSET is given (default 2.74 mm, the map `tacsim sim2real` fits for the edge-2d recipe) or,
with `free`, searched with SHIFT; SHIFT is searched over -1..0.6 mm. Printed: the rms error of
each feature over the real taps the set covers, the best SHIFT, the share covered, and the
features by lateral band for the shallow (pose_3 < 3.6 mm) and deep (> 4.3 mm) taps.
Needs numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/ring_response.py ../shared/data/real-tactip-edge2d [OFFSET|free] SIMSET...
"""
import csv
import sys

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from image_change_fit import alike_group  # noqa: E402
from radial_signature import CENTRE, FIELD, load, pins  # noqa: E402

BANDS = [(4, 16), (16, 28), (28, 44)]
NAMES = ["inner", "mid", "outer", "change"]


def track(found, rest_all, tree):
    """Each reference pin's displacement (px; NaN where unmatched): matched within 2 px of its
    rest place, then twice more within 2 px of the place its matched neighbours' mean
    displacement (within 8 px) predicts, so that motions past half a pin spacing still match
    where the field is smooth."""
    moved = np.full_like(rest_all, np.nan)
    found_tree = cKDTree(found)
    guess = rest_all.copy()
    for _ in range(3):
        distance, nearest = found_tree.query(guess, distance_upper_bound=2.0)
        ok = np.isfinite(distance)
        moved[:] = np.nan
        moved[ok] = found[nearest[ok]] - rest_all[ok]
        for i in np.where(~ok)[0]:
            near = [j for j in tree.query_ball_point(rest_all[i], 8.0) if ok[j]]
            if near:
                guess[i] = rest_all[i] + moved[near].mean(0)
    return moved


def features(images, reference):
    rest_all = pins(reference)
    tree = cKDTree(rest_all)
    outward = rest_all - CENTRE
    r = np.hypot(*outward.T)
    out = []
    for image in images:
        moved = track(pins(image), rest_all, tree)
        radial = (moved * outward).sum(1) / np.maximum(r, 1e-9)
        out.append([np.nanmean(radial[(r > lo) & (r < hi)]) for lo, hi in BANDS] + [10 * (image ^ reference)[FIELD].mean()])
    return np.array(out)


def fit(real, sim, offsets):
    (rl, rd, rf), (sx, sz, sf) = real, sim
    best = None
    for offset in offsets:
        for shift in np.arange(-1.0, 0.61, 0.1):
            lateral, depth = offset - sx, sz + shift
            ok = (rl >= lateral.min()) & (rl <= lateral.max()) & (rd >= depth.min()) & (rd <= depth.max())
            d2 = ((rl[ok, None] - lateral[None]) / 0.4) ** 2 + ((rd[ok, None] - depth[None]) / 0.1) ** 2
            w = np.exp(-0.5 * d2)
            predicted = (w / (w.sum(1, keepdims=True) + 1e-12)) @ sf
            error = np.sqrt(np.mean((predicted - rf[ok]) ** 2, 0))
            # Real taps the set cannot reach count against it.
            score = error.mean() + 0.5 * (1 - ok.mean())
            if best is None or score < best[0]:
                best = (score, offset, shift, error, ok, predicted)
    return best


def main(real_dir, offset, sim_dirs):
    rows = list(csv.DictReader(open(f"{real_dir}/targets.csv")))
    rd = np.array([float(r["pose_3"]) for r in rows])
    rl = np.array([float(r["pose_2"]) for r in rows])
    images = np.array([load(f"{real_dir}/images/{r['sensor_image']}") for r in rows])
    rf = features(images, images[alike_group(images, rd)].mean(0) > 0.5)
    offsets = np.arange(-1.0, 4.01, 0.25) if offset == "free" else [float(offset)]
    for folder in sim_dirs:
        srows = list(csv.DictReader(open(f"{folder}/targets.csv")))
        sx = np.array([float(r["pose_x"]) for r in srows])
        sz = np.array([float(r["pose_z"]) for r in srows])
        sf = features([load(f"{folder}/images/{r['sensor_image']}") for r in srows], load(f"{folder}/images/image_0.png"))
        score, off, shift, error, ok, predicted = fit((rl, rd, rf), (sx, sz, sf), offsets)
        rms = " ".join(f"{n} {e:.3f}" for n, e in zip(NAMES, error))
        print(f"{folder}: offset {off:+.2f} mm, depth shift {shift:+.1f} mm, covers {ok.mean():.0%}; rms {rms}")
        print("   lateral (mm)  depth      real inner/mid/outer/change   simulated")
        for lo in range(-6, 6, 2):
            for name, band in [("shallow", rd[ok] < 3.6), ("deep", rd[ok] > 4.3)]:
                m = band & (rl[ok] >= lo) & (rl[ok] < lo + 2)
                if m.any():
                    real_cells = " ".join(f"{v:+.2f}" for v in rf[ok][m].mean(0))
                    sim_cells = " ".join(f"{v:+.2f}" for v in predicted[m].mean(0))
                    print(f"   [{lo:+d}, {lo + 2:+d})      {name:8s}  {real_cells}   {sim_cells}")


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    if sys.argv[2] == "free" or sys.argv[2].lstrip("+-").replace(".", "", 1).isdigit():
        main(sys.argv[1], sys.argv[2], sys.argv[3:])
    else:
        main(sys.argv[1], "2.74", sys.argv[2:])
