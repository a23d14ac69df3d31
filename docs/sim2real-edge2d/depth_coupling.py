"""How the simulator-trained network's lateral reading of the lab's edge taps depends on the
depth, read on the lab's fitting part (a `tacsim sim2real` run's fitting.csv and report.json,
not its held-out part). Printed:
- per depth band: the lateral reading's straight line against the label (offset, gain), the
  scatter left after it, and the depth reading's bias;
- per lateral band: the lateral bias's slope against the depth;
- the held-out lateral error (predictions.csv) before and after taking off the lateral bias's
  line in the depth fitted on the fitting part (a diagnosis of how much of the error that
  coupling is, not a map for the benchmark);
- with the recipe it ran: its depth map (`[rig]`) refitted so that a label presses as deep as
  the network reads the lab's taps of that label. The network reads a real tap at depth z as
  the simulated depth z' = a + b z (least squares); the new map presses z as the old one
  pressed z'; the rig's form (commanded c = z + depth_offset_mm, indentation
  c - depth_compliance c^1.5, mm) is fitted to that by a grid search.
Plain Python 3.11.

    python3 docs/sim2real-edge2d/depth_coupling.py WORK [RECIPE.toml]
"""
import csv
import json
import re
import sys
import tomllib


def line(xs, ys):
    n = len(xs)
    mx, my = sum(xs) / n, sum(ys) / n
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    return my - b * mx, b


def press(z, offset, compliance):
    c = z + offset
    return c - compliance * max(c, 0.0) ** 1.5


def mean(v):
    return sum(v) / len(v)


def main(work, recipe_path=None):
    rows = list(csv.DictReader(open(f"{work}/fitting.csv")))
    held = list(csv.DictReader(open(f"{work}/predictions.csv")))
    labels = [c[: -len("_sim_trained")] for c in rows[0] if c.endswith("_sim_trained")]
    lat, dep = labels[0], labels[1]
    get = lambda r, c: float(r[c])
    read = lambda r, c: float(r[c + "_sim_trained"])
    z = [get(r, dep) for r in rows]
    lo, hi = min(z), max(z)
    print(f"{work}: {len(rows)} fitting taps, {len(held)} held out; lateral {lat}, depth {dep}")
    step = (hi - lo) / 4
    for k in range(4):
        a0, a1 = lo + k * step, lo + (k + 1) * step
        band = [r for r in rows if a0 <= get(r, dep) < a1 or (k == 3 and get(r, dep) == hi)]
        off, gain = line([get(r, lat) for r in band], [read(r, lat) for r in band])
        scatter = mean([abs(read(r, lat) - off - gain * get(r, lat)) for r in band])
        print(f"  {dep} {a0:.2f}..{a1:.2f} mm ({len(band)}): {lat} read as {off:+.2f} + {gain:.2f} {lat}, "
              f"scatter {scatter:.2f} mm; {dep} bias {mean([read(r, dep) - get(r, dep) for r in band]):+.2f} mm")
    ys = [get(r, lat) for r in rows]
    ylo, yhi = min(ys), max(ys)
    for k in range(5):
        a0, a1 = ylo + k * (yhi - ylo) / 5, ylo + (k + 1) * (yhi - ylo) / 5
        band = [r for r in rows if a0 <= get(r, lat) < a1 or (k == 4 and get(r, lat) == yhi)]
        off, slope = line([get(r, dep) for r in band], [read(r, lat) - get(r, lat) for r in band])
        print(f"  {lat} {a0:+.1f}..{a1:+.1f} mm ({len(band)}): {lat} bias {off + slope * 4.0:+.2f} mm at {dep} 4, {slope:+.2f} mm per mm of {dep}")
    c0, c1 = line(z, [read(r, lat) - get(r, lat) for r in rows])
    before = mean([abs(read(r, lat) - get(r, lat)) for r in held])
    after = mean([abs(read(r, lat) - c0 - c1 * get(r, dep) - get(r, lat)) for r in held])
    print(f"  {lat} bias on the fitting part {c0:+.2f} {c1:+.2f} {dep} mm; held-out {lat} error {before:.2f} mm, {after:.2f} without that line")
    if recipe_path is None:
        return
    recipe = tomllib.load(open(recipe_path, "rb"))
    rig = recipe["rig"]
    offset, compliance = rig["depth_offset_mm"], rig.get("depth_compliance", 0.0)
    zlo, zhi = recipe["poses"]["depth_mm"]
    report = json.load(open(f"{work}/report.json"))
    link = next(m for m in report["map"] if m.startswith(f"lab {dep} "))
    sign, _, shift = re.search(r"= (-?)sim (\S+) \(mm\) ([+-] [\d.]+)", link).groups()
    if sign == "-":
        sys.exit(f"{link}: the depth's link is negated; this script reads a positive one")
    shift = float(shift.replace(" ", ""))
    a, b = line(z, [read(r, dep) for r in rows])
    zs = [zlo + (zhi - zlo) * i / 40 for i in range(41)]
    want = [press(a + b * v - shift, offset, compliance) for v in zs]
    best = None
    for oi in range(-500, 1):
        o = oi / 100
        if zlo + o <= 0:
            continue
        for ki in range(0, 401):
            k = ki / 1000
            if any(1.0 - 1.5 * k * (v + o) ** 0.5 <= 0 for v in zs):
                continue
            e = sum((press(v, o, k) - w) ** 2 for v, w in zip(zs, want))
            if best is None or e < best[0]:
                best = (e, o, k)
    e, o, k = best
    print(f"  {dep} read as {a:.3f} + {b:.3f} {dep} ({link}); indentation at {zlo} / {zhi} mm: "
          f"{press(zlo, offset, compliance):.3f} / {press(zhi, offset, compliance):.3f}, wanted {want[0]:.3f} / {want[-1]:.3f}, "
          f"refitted {press(zlo, o, k):.3f} / {press(zhi, o, k):.3f} (rms {(e / len(zs)) ** 0.5:.3f} mm)")
    print(f"[rig]\ndepth_offset_mm = {o:.2f}\ndepth_compliance = {k:.3f}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
