"""Both networks on the held-out edge taps beside the edge (issue 85: "the shallow taps 4-6 mm
beside the edge included"), from a `tacsim sim2real` run's predictions.csv: per label (lateral,
depth, yaw) the simulator-trained and the real-trained networks' mean absolute errors and
their ratio, on every held-out tap, on those 4-6 mm beside the edge (|lateral| 4-6 mm), and on
those of them shallower than 4 mm and 3.5 mm (the depths run 3-5 mm). Needs numpy.

    python3 docs/sim2real-edge2d/beside_edge.py RUN/predictions.csv [RUN2/predictions.csv ...]
"""
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from predictions import read  # noqa: E402


def main(paths):
    for path in paths:
        labels, col, _ = read(path)
        y, z = col(labels[0]), col(labels[1])
        beside = (np.abs(y) >= 4) & (np.abs(y) <= 6)
        print(path)
        for name, m in (("every tap", np.ones(len(y), bool)), ("|lateral| 4-6 mm", beside),
                        ("|lateral| 4-6 mm, depth < 4 mm", beside & (z < 4)),
                        ("|lateral| 4-6 mm, depth < 3.5 mm", beside & (z < 3.5))):
            parts = []
            for label in labels:
                def error(who):
                    e = col(f"{label}_{who}") - col(label)
                    return np.abs((e + 180) % 360 - 180 if label.endswith("Rz") else e)[m].mean()
                sim, real = error("sim_trained"), error("real_trained")
                parts.append(f"{label} {sim:.3f} / {real:.3f} ({sim / real:.2f}x)")
            print(f"  {name} ({m.sum()} taps): " + ", ".join(parts))


if __name__ == "__main__":
    main(sys.argv[1:])
