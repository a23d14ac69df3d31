"""How the inner and outer pins of edge taps move towards or away from the image centre, by
lateral offset and depth, real against simulated (issue 30).

Both sides are measured alike: each image's pins (blobs of 2-30 px within 44 px of the
centre at 128 px) are matched within 2 px to the pins of the undeformed reference, and the
mean radial displacement (px, + outward) is reported for the pins at 10-25 px from the centre
(inner) and beyond 30 px (outer); then, for the real taps, the inner pins' mean translation in
a frame turned with the yaw (how much of their motion is a shift rather than a contraction);
then the share of the pin field's pixels that differ from the reference, for the taps
shallower than 3.3 mm. The reference: of the real taps, the pixel-wise majority of the 30 most
alike of the shallowest half, as `tacsim calibrate` builds it for a folder without an
undeformed image (taps that touch nothing); of a simulated set, its undeformed image_0.png.
With REFERENCE `shallowest`, both sides take the majority of their 75 shallowest taps instead,
the rule before: the real ones among them press the material, so that reference is not
undeformed and every real tap looked contracted against it (docs/guide/sim2real.md). A
simulated set's labels are turned into the lab's lateral offset through the sim2real label
map's offset (lab = OFFSET - simulated x), and only its taps within the lab's -6..6 mm are
used. Needs numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/radial_signature.py real ../shared/data/real-tactip-edge2d [- REFERENCE]
    python3 docs/sim2real-edge2d/radial_signature.py sim target/sim2real-edge2d/sim 2.74 [REFERENCE [DEPTH_SHIFT]]
"""
import csv
import sys

import numpy as np
from PIL import Image
from scipy import ndimage
from scipy.spatial import cKDTree

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from image_change_fit import alike_group  # noqa: E402

CENTRE = np.array([64.4, 64.5])
# The pin field: pixels within 46 px of the centre at 128 px.
FIELD = np.hypot(*(np.mgrid[0:128, 0:128][::-1] - CENTRE[:, None, None] + 0.5)) < 46


def load(path):
    return np.array(Image.open(path).convert("L")) > 127


def pins(image):
    labels, n = ndimage.label(image)
    index = np.arange(1, n + 1)
    area = ndimage.sum(image, labels, index)
    centres = np.array(ndimage.center_of_mass(image, labels, index))[:, ::-1] + 0.5
    keep = (area >= 2) & (area <= 30) & (np.hypot(*(centres - CENTRE).T) < 44)
    return centres[keep]


def radial(found, reference, tree):
    distance, nearest = tree.query(found, distance_upper_bound=2.0)
    ok = np.isfinite(distance)
    moved, rest = found[ok], reference[nearest[ok]]
    out = rest - CENTRE
    r = np.hypot(*out.T)
    along = ((moved - rest) * out).sum(1) / np.maximum(r, 1e-9)
    return along[r > 30].mean(), along[(r > 10) & (r < 25)].mean()


def main(kind, folder, offset="-", reference="alike", depth_shift="0"):
    rows = list(csv.DictReader(open(f"{folder}/targets.csv")))
    if kind == "real":
        depth = np.array([float(r["pose_3"]) for r in rows])
        lateral = np.array([float(r["pose_2"]) for r in rows])
    else:
        # DEPTH_SHIFT (mm) puts labels that are the indentation into the lab's pose_3.
        depth = np.array([float(r["pose_z"]) + float(depth_shift) for r in rows])
        lateral = float(offset) - np.array([float(r["pose_x"]) for r in rows])
        # The lab's range only, so that both consensus images come from the same span.
        keep = np.abs(lateral) <= 6.0
        rows = [r for r, k in zip(rows, keep) if k]
        depth, lateral = depth[keep], lateral[keep]
    images = [load(f"{folder}/images/{r['sensor_image']}") for r in rows]
    if reference == "shallowest":
        consensus = np.array(images)[np.argsort(depth)[:75]].mean(0) > 0.5
    elif kind == "real":
        stack = np.array(images)
        group = alike_group(stack, depth)
        consensus = stack[group].mean(0) > 0.5
        # How alike the chosen taps are, and how far the old rule's reference lies from them.
        pairs = [(stack[i] ^ stack[j])[FIELD].mean() for n, i in enumerate(group) for j in group[n + 1 :]]
        old = stack[np.argsort(depth)[:75]].mean(0) > 0.5
        print(
            f"reference: the {len(group)} most alike of the shallowest half, lateral "
            f"{lateral[group].min():+.1f}..{lateral[group].max():+.1f} mm, pose_3 <= {depth[group].max():.2f} mm; "
            f"they differ from each other in {np.mean(pairs):.2%} of the pin field's pixels, "
            f"from the majority of the 75 shallowest (the old rule) in {np.mean([(stack[i] ^ old)[FIELD].mean() for i in group]):.2%}"
        )
    else:
        consensus = load(f"{folder}/images/image_0.png")
    reference = pins(consensus)
    tree = cKDTree(reference)
    moves = np.array([radial(pins(im), reference, tree) for im in images])
    print(f"{kind} {folder}: outer / inner mean radial displacement (px) from the consensus, by depth band")
    bands = [(3.0, 3.4), (3.4, 3.8), (3.8, 4.2), (4.2, 4.6), (4.6, 5.01)]
    print("lateral (mm)   " + "   ".join(f"{a:.1f}-{b:.1f} mm" for a, b in bands))
    for lo, hi in [(-6, -4), (-4, -2), (-2, 0), (0, 2), (2, 4), (4, 6)]:
        cells = []
        for a, b in bands:
            m = (lateral >= lo) & (lateral < hi) & (depth >= a) & (depth < b)
            cells.append(f"{moves[m, 0].mean():+.2f}/{moves[m, 1].mean():+.2f}" if m.any() else "   -   ")
        print(f"[{lo:+d}, {hi:+d})      " + "   ".join(cells))
    # The share of pin-field pixels (within 46 px) that differ from the consensus, shallow taps.
    change = np.array([(im ^ consensus)[FIELD].mean() for im in images])
    shallow = depth < 3.3
    if kind == "real":
        # Translation against contraction: the inner pins' mean displacement turned by minus
        # the yaw (so the edge keeps one direction), taps shallower than 3.4 mm.
        yaw = np.radians([float(r["pose_6"]) for r in rows])
        print("inner pins, taps shallower than 3.4 mm: mean translation in the yaw-turned frame (px)")
        for lo, hi in [(-6, -4), (-4, -2), (4, 6)]:
            moved = []
            for i in np.where((lateral >= lo) & (lateral < hi) & (depth < 3.4))[0]:
                found = pins(images[i])
                distance, nearest = tree.query(found, distance_upper_bound=2.0)
                ok = np.isfinite(distance)
                rest = reference[nearest[ok]]
                r = np.hypot(*(rest - CENTRE).T)
                inner_pins = (r > 10) & (r < 25)
                v = (found[ok] - rest)[inner_pins].mean(0)
                c, s = np.cos(-yaw[i]), np.sin(-yaw[i])
                moved.append([c * v[0] - s * v[1], s * v[0] + c * v[1]])
            m = np.mean(moved, 0)
            print(f"[{lo:+d}, {hi:+d})      ({m[0]:+.2f}, {m[1]:+.2f}) |{np.hypot(*m):.2f}|")
    print("pixels changed, taps shallower than 3.3 mm, by lateral (mm):")
    for lo, hi in [(-6, -4), (-4, -2), (-2, 0), (0, 2), (2, 4), (4, 6)]:
        m = shallow & (lateral >= lo) & (lateral < hi)
        print(f"[{lo:+d}, {hi:+d})      {change[m].mean():.4f} ({m.sum()} taps)")


if __name__ == "__main__":
    main(*sys.argv[1:])
