"""The depth's bias on the held-out real edge taps by lateral band and depth band, for both
networks of a `tacsim sim2real` run (its predictions.csv: the first two labels are the lateral
offset and the depth, a third, where there is one, the yaw). Printed per network: the mean
absolute errors, then a table of the mean depth error (reading - label, mm) with a row per
lateral band -6..-4 ... 4..6 mm and a column per depth band 3.0-3.5 ... 4.5-5.0 mm (a cell of 3
taps or fewer left blank); last, per lateral band, both networks' mean absolute errors of the
shallowest taps (3.0-3.5 mm, the taps beside the edge that barely touch) and of the rest.
A run's fitting.csv (the lab's fitting taps, the simulator-trained network's readings through
the label map fitted on them) reads the same way, that network alone: the taps a choice of
the simulator may be judged on, the held-out ones left to score it. Needs numpy.

    python3 docs/sim2real-edge2d/depth_bands.py WORK/predictions.csv
    python3 docs/sim2real-edge2d/depth_bands.py WORK/fitting.csv
"""
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from predictions import LATERAL_BANDS, band_table, depth_header, read  # noqa: E402


def yaw_error(col, angle, who):
    """The yaw reading's error (deg), wrapped into [-180, 180)."""
    return (col(f"{angle}_{who}") - col(angle) + 180) % 360 - 180


def main(path):
    labels, col, has = read(path)
    lateral, depth = labels[0], labels[1]
    y, z = col(lateral), col(depth)
    networks = [who for who in ("sim_trained", "real_trained") if has(f"{lateral}_{who}")]
    angle = labels[2] if len(labels) > 2 else None
    for who in networks:
        ey, ez = col(f"{lateral}_{who}") - y, col(f"{depth}_{who}") - z
        yaw = f", yaw {np.abs(yaw_error(col, angle, who)).mean():.2f} deg" if angle else ""
        print(f"{who}: lateral {np.abs(ey).mean():.3f} mm, depth {np.abs(ez).mean():.3f} mm{yaw}; depth bias (mm):")
        print("  lateral \\ depth  " + " ".join(depth_header()))
        cell = lambda k: f"{ez[k].mean():+7.2f}" if k.sum() > 3 else "       "  # noqa: E731
        for name, cells in band_table(y, z, cell):
            print(f"  {name}      " + " ".join(cells))
    print("mean absolute errors by lateral band, lateral / depth (mm)" + (" / yaw (deg)" if angle else "")
          + (", simulator-trained against real-trained:" if len(networks) > 1 else ", simulator-trained:"))
    for lo in LATERAL_BANDS:
        for name, part in (("3.0-3.5 mm", z < 3.5), ("3.5-5.0 mm", z >= 3.5)):
            k = (y >= lo) & (y < lo + 2) & part
            if k.sum() == 0:
                continue
            text = []
            for who in networks:
                e = [np.abs(col(f"{lateral}_{who}") - y)[k].mean(), np.abs(col(f"{depth}_{who}") - z)[k].mean()]
                if angle:
                    e.append(np.abs(yaw_error(col, angle, who))[k].mean())
                text.append(" / ".join(f"{v:.2f}" for v in e))
            print(f"  {lo:+d}..{lo + 2:+d} mm, {name} ({k.sum()} taps): " + " against ".join(text))


if __name__ == "__main__":
    main(sys.argv[1])
