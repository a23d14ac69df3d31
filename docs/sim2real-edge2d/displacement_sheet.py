"""A sheet of pin displacement fields, real edge taps beside simulated ones at the same labels
(issue 30): each pin's motion from the undeformed reference (tracked as in ring_response.py),
drawn six times its length from its rest place. Rows: the real tap nearest each of lab lateral -4, -2, 0, 2, 4 mm at the given
depth (`pose_3`, mm) and yaw near -120 deg; columns: the real tap, then for each OFFSET the
simulated tap nearest its labels through lab lateral = OFFSET - simulated x and lab yaw =
-(simulated yaw) - 175.6 deg (the sim2real map of the edge-2d recipe). References as in
ring_response.py. Needs numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/displacement_sheet.py ../shared/data/real-tactip-edge2d SIMSET OUT.png 0,2.74 4.7
"""
import csv
import sys

import numpy as np
from PIL import Image, ImageDraw
from scipy.spatial import cKDTree

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from image_change_fit import alike_group  # noqa: E402
from radial_signature import load, pins  # noqa: E402
from ring_response import track  # noqa: E402

SCALE = 4
STRETCH = 6


def field(image, reference):
    rest_all = pins(reference)
    moved = track(pins(image), rest_all, cKDTree(rest_all))
    ok = np.isfinite(moved[:, 0])
    tile = Image.new("L", (128 * SCALE, 128 * SCALE))
    draw = ImageDraw.Draw(tile)
    for rest, motion in zip(rest_all[ok], moved[ok]):
        end = rest + motion * STRETCH
        draw.line([tuple(rest * SCALE), tuple(end * SCALE)], fill=255, width=2)
        x, y = rest * SCALE
        draw.ellipse([x - 2, y - 2, x + 2, y + 2], fill=120)
    return np.pad(np.array(tile), 4, constant_values=60)


def turn(a):
    return (a + 180.0) % 360.0 - 180.0


def main(real_dir, sim_dir, out, offsets, depth):
    rows = list(csv.DictReader(open(f"{real_dir}/targets.csv")))
    rd = np.array([float(r["pose_3"]) for r in rows])
    rl = np.array([float(r["pose_2"]) for r in rows])
    ry = np.array([float(r["pose_6"]) for r in rows])
    images = np.array([load(f"{real_dir}/images/{r['sensor_image']}") for r in rows])
    real_reference = images[alike_group(images, rd)].mean(0) > 0.5
    srows = list(csv.DictReader(open(f"{sim_dir}/targets.csv")))
    sx = np.array([float(r["pose_x"]) for r in srows])
    sz = np.array([float(r["pose_z"]) for r in srows])
    sy = np.array([float(r["pose_Rz"]) for r in srows])
    sim_reference = load(f"{sim_dir}/images/image_0.png")
    sheet = []
    for lateral in [-4, -2, 0, 2, 4]:
        i = np.argmin(np.abs(rl - lateral) + 3 * np.abs(rd - depth) + 0.02 * np.abs(turn(ry + 120)))
        row = [field(images[i], real_reference)]
        line = f"real lateral {rl[i]:+.2f} mm, pose_3 {rd[i]:.2f} mm, yaw {ry[i]:.0f} deg"
        for offset in offsets:
            yaw = -ry[i] - 175.6
            j = np.argmin(np.abs(offset - sx - rl[i]) + 3 * np.abs(sz - rd[i]) + 0.02 * np.abs(turn(sy - yaw)))
            row.append(field(load(f"{sim_dir}/images/{srows[j]['sensor_image']}"), sim_reference))
            line += f" | offset {offset:+.2f}: simulated x {sx[j]:+.2f} mm"
        print(line)
        sheet.append(np.concatenate(row, 1))
    Image.fromarray(np.concatenate(sheet, 0).astype(np.uint8)).save(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    if len(sys.argv) != 6:
        sys.exit(__doc__)
    real_dir, sim_dir, out, offsets, depth = sys.argv[1:]
    main(real_dir, sim_dir, out, [float(o) for o in offsets.split(",")], float(depth))
