"""How far the dome's far-field table (`PinResponse::spread`, `fem/src/response.rs`) can be cut
to a low rank: its singular values, and the pins' error at rank r under a few model loads.

Reads a dome's cache file (`tacsim-pins-<key>.bin` in the cache folder; the header names the
dome), takes the table's 6 P rows (each pin's tip displacement in mm and its post's turn in
rad, per unit force on an outer node) against its 3 N columns, and prints (a) the share of the
table's energy beyond rank r and s_r / s_0, (b) for loads of 4 N spread as `sqrt(1 - (d/a)^2)`
over the outer nodes within a chord distance `a` of a point on the dome (with a tangential
load 0.3 of it), the largest tip error (mm) and turn error (rad) left when the pins' motion is
projected on the table's first r left singular vectors (what a table stored as `U_r (U_r^T T)`
gives). Needs numpy; about 10 s and 1 GB for the default dome.

    python3 docs/experiments/dome-far-field/table_rank.py ~/.cache/tacsim/tacsim-pins-KEY.bin
"""

import json
import sys

import numpy as np

MAGIC = b"TACSIMPINS1\n"
RANKS = (100, 200, 300, 400, 600, 800)
# (degrees from the apex, chord radius a in mm) of the model loads
LOADS = ((0, 8), (0, 3), (25, 6), (40, 4), (10, 1.5))


def read(path):
    b = open(path, "rb").read()
    if not b.startswith(MAGIC):
        sys.exit(f"{path}: not a tacsim pin-response cache file")
    n = int.from_bytes(b[len(MAGIC):len(MAGIC) + 8], "little")
    off = len(MAGIC) + 8
    h = json.loads(b[off:off + n])
    off += n
    nodes = np.frombuffer(b, np.float64, 3 * h["nodes"], off).reshape(-1, 3)
    off += 24 * h["nodes"] + 24 * h["faces"]
    rows = 6 * h["pins"]
    table = np.frombuffer(b, np.float32, rows * 3 * h["nodes"], off).reshape(3 * h["nodes"], rows)
    return h, nodes, table.astype(np.float64)


def load(nodes, radius, centre_deg, a):
    t = np.radians(centre_deg)
    c = radius * np.array([np.sin(t), 0.0, np.cos(t)])
    d = np.linalg.norm(nodes - c, axis=1)
    p = np.where(d < a, np.sqrt(np.clip(1 - (d / a) ** 2, 0, None)), 0.0)
    p *= 4.0 / p.sum()
    f = np.zeros((len(nodes), 3))
    f[:, 2], f[:, 0] = -p, 0.3 * p
    return f.reshape(-1)


def main(path):
    h, nodes, table = read(path)
    print(f"{h['nodes']} outer nodes, {h['pins']} pins, patch s {h['spread_mm']:.3f} mm; {h['spec'][:160]}...")
    w, u = np.linalg.eigh(table.T @ table)
    s, u = np.sqrt(np.clip(w[::-1], 0, None)), u[:, ::-1]
    energy = (s ** 2).sum()
    print("rank r: energy beyond r, s_r / s_0")
    for r in RANKS:
        print(f"  {r:4d}: {(s[r:] ** 2).sum() / energy:.2e}, {s[r] / s[0]:.2e}")
    turn = np.zeros(table.shape[1], bool)
    for k in range(h["pins"]):
        turn[6 * k + 3:6 * k + 6] = True
    for centre, a in LOADS:
        m = table.T @ load(nodes, h["radius_mm"], centre, a)
        print(f"load {centre} deg from the apex, a {a} mm: largest tip motion {np.abs(m[~turn]).max():.3f} mm, "
              f"turn {np.abs(m[turn]).max():.4f} rad; error at rank r, tip (mm) / turn (rad):")
        for r in RANKS:
            e = m - u[:, :r] @ (u[:, :r].T @ m)
            print(f"  {r:4d}: {np.abs(e[~turn]).max():.1e} / {np.abs(e[turn]).max():.1e}")


if __name__ == "__main__":
    main(sys.argv[1])
