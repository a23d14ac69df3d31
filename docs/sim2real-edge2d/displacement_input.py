"""Pin displacement fields as the pose network's input (issue 30): writes a copy of an edge
folder whose images are each tap's pin motion instead of its pin pattern, so that
`tacsim sim2real --real DST --sim DST2` trains and tests on motion alone.

Each image's pins (blobs as in radial_signature.py) are tracked from its domain's reference
(ring_response.py's tracker): a lab folder's consensus of the taps that touch nothing (as
`tacsim calibrate` builds it), a simulated set's undeformed image (meta.json
`reference_image`). The displacements (px at 128 px) are spread on a 32x32 grid over the image
(Gaussian weights about each pin's rest place, sigma 3 px, normalised, fading to 0 where no pin
is near) and written as a 64x64 grey PNG: dx in the top half, dy below, each column doubled,
grey = 0.5 + d / 8 px. A simulated set's meta.json gets `image_size = 64`. Needs numpy,
pillow, scipy.

    python3 docs/sim2real-edge2d/displacement_input.py ../shared/data/real-tactip-edge2d WORK/real-motion real
    python3 docs/sim2real-edge2d/displacement_input.py WORK/sim WORK/sim-motion sim
"""
import csv
import json
import os
import shutil
import sys

import numpy as np
from PIL import Image
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from image_change_fit import consensus  # noqa: E402
from radial_signature import load, pins  # noqa: E402
from ring_response import track  # noqa: E402

SIGMA_PX = 3.0
GRID = 32
_g = (np.arange(GRID) + 0.5) * (128 / GRID)
POINTS = np.stack([c.ravel() for c in np.meshgrid(_g, _g)], 1)


def motion_image(image, rest, tree):
    moved = track(pins(image), rest, tree)
    ok = np.isfinite(moved[:, 0])
    w = np.exp(-((POINTS[:, None, :] - rest[ok][None]) ** 2).sum(-1) / (2 * SIGMA_PX**2))
    f = (w @ moved[ok]) / (w.sum(1, keepdims=True) + 0.1)
    out = np.vstack([f[:, 0].reshape(GRID, GRID), f[:, 1].reshape(GRID, GRID)]).repeat(2, axis=1)
    return (np.clip(0.5 + out / 8, 0, 1) * 255 + 0.5).astype(np.uint8)


def main(src, dst, kind):
    rows = list(csv.DictReader(open(f"{src}/targets.csv")))
    names = [r["sensor_image"] for r in rows]
    if kind == "real":
        images = np.array([load(f"{src}/images/{n}") for n in names])
        reference = consensus(images, np.array([float(r["pose_3"]) for r in rows]))
    elif kind == "sim":
        reference_name = json.load(open(f"{src}/meta.json"))["reference_image"]
        reference = load(f"{src}/images/{reference_name}")
        names.append(reference_name)
    else:
        sys.exit(__doc__)
    rest = pins(reference)
    tree = cKDTree(rest)
    os.makedirs(f"{dst}/images", exist_ok=True)
    for f in os.listdir(src):
        if os.path.isfile(f"{src}/{f}"):
            shutil.copy(f"{src}/{f}", f"{dst}/{f}")
    if kind == "sim":
        meta = json.load(open(f"{dst}/meta.json"))
        meta["image_size"] = 64
        json.dump(meta, open(f"{dst}/meta.json", "w"), indent=1)
    for n in names:
        Image.fromarray(motion_image(load(f"{src}/images/{n}"), rest, tree)).save(f"{dst}/images/{n}")
    print(f"{dst}: {len(names)} images, {len(rest)} reference pins")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
