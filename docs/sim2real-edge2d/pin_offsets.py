"""How far a simulated set's undeformed pins sit from the real edge TacTip's, blob to blob
(issue 30): the pins of the set's image_0.png (blobs as in radial_signature.py) matched within
1.5 px to the pins of the real folder's consensus reference (`alike`: the majority of the 30
most alike of the shallowest half, taps that touch nothing, `tacsim calibrate`'s default; or
`shallowest`: the majority of the 75 shallowest), and the RMS and mean of their offsets (px at
128). With OUT.json it also writes the offsets as a table ({"size": 128, "pins": [[u, v, du,
dv], ...]}). Needs numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/pin_offsets.py ../shared/data/real-tactip-edge2d SIMSET [alike|shallowest] [OUT.json]
"""
import csv
import json
import sys

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from image_change_fit import alike_group  # noqa: E402
from radial_signature import load, pins  # noqa: E402


def main(real, simset, rule="alike", out=None):
    rows = list(csv.DictReader(open(f"{real}/targets.csv")))
    depth = np.array([float(r["pose_3"]) for r in rows])
    images = np.array([load(f"{real}/images/{r['sensor_image']}") for r in rows])
    group = np.argsort(depth, kind="stable")[:75] if rule == "shallowest" else alike_group(images, depth)
    real_pins = pins(images[group].mean(0) > 0.5)
    sim_pins = pins(load(f"{simset}/images/image_0.png"))
    distance, nearest = cKDTree(real_pins).query(sim_pins, distance_upper_bound=1.5)
    ok = np.isfinite(distance)
    offsets = np.zeros_like(sim_pins)
    offsets[ok] = real_pins[nearest[ok]] - sim_pins[ok]
    rms = np.sqrt((offsets[ok] ** 2).sum(1).mean())
    print(f"{simset}: {len(sim_pins)} pins, {ok.sum()} matched to the real {rule} reference: RMS {rms:.3f} px, mean {offsets[ok].mean(0).round(3)}")
    if out:
        table = [[float(a), float(b), float(c), float(d)] for (a, b), (c, d) in zip(sim_pins, offsets)]
        json.dump({"size": 128, "pins": table}, open(out, "w"))


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(*sys.argv[1:])
