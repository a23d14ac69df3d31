"""Joins simulated datasets into one for `tacsim sim2real --sim` (issue 30's mixtures):
images hard-linked as d{K}_NAME, rows concatenated (pose ids kept apart), meta.json from the
first set with the counts summed. `DIR:LO:HI` maps that set's depth labels linearly from
[LO, HI] mm (its indentation range) onto the lab's 3..5 mm; `DIR:convex:K:ZERO` labels a set
pressed over indentations i with the lab depth d of the convex map i = c + K c^1.5,
c = d - ZERO.

    python3 docs/sim2real-edge2d/join_datasets.py OUT DIR[:LO:HI]...
"""
import csv, json, os, shutil, sys
out, dirs = sys.argv[1], sys.argv[2:]
os.makedirs(out + "/images", exist_ok=True)
rows, header, meta = [], None, None
for k, spec in enumerate(dirs):
    d, *rng = spec.split(":")
    m = json.load(open(d + "/meta.json"))
    if meta is None:
        meta = dict(m); meta["samples"] = 0; meta["taps"] = 0; meta["slides"] = 0
        shutil.copy(d + "/images/" + m["reference_image"], out + "/images/" + m["reference_image"])
    meta["samples"] += m["samples"]; meta["taps"] += m["taps"]; meta["slides"] += m["slides"]
    with open(d + "/targets.csv") as f:
        r = csv.DictReader(f); header = r.fieldnames
        for row in r:
            name = f"d{k}_" + row["sensor_image"]
            os.link(d + "/images/" + row["sensor_image"], out + "/images/" + name)
            row["sensor_image"] = name
            if rng and rng[0] == "convex":
                kc, zero = map(float, rng[1:])
                i = float(row["pose_z"])
                c = max(i, 1e-6)
                for _ in range(50):  # Newton on c + kc c^1.5 = i
                    c = max(c - (c + kc * c**1.5 - i) / (1 + 1.5 * kc * c**0.5), 1e-9)
                row["pose_z"] = repr(c + zero)
            elif rng:
                lo, hi = map(float, rng)
                row["pose_z"] = repr(3.0 + 2.0 * (float(row["pose_z"]) - lo) / (hi - lo))
            for c in ("pose_id", "pair_id"):
                if c in row and row[c] not in ("", None):
                    row[c] = str(int(row[c]) + 1000000 * k)
            rows.append(row)
with open(out + "/targets.csv", "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=header, lineterminator="\n"); w.writeheader(); w.writerows(rows)
json.dump(meta, open(out + "/meta.json", "w"), indent=2)
print(len(rows), "rows")
