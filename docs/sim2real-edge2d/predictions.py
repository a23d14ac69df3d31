"""A `tacsim sim2real` run's predictions.csv read by band, for the edge taps' diagnoses
(lateral_bias.py, yaw_cells.py, depth_bands.py): the labels with a `_sim_trained` reading
(the lateral offset, the depth and, where there is one, the yaw last), each column as an array,
and a table of lateral bands (2 mm, -6..-4 ... 4..6 mm) by depth bands (0.5 mm, 3.0-3.5 ...
4.5-5.0 mm). Needs numpy.
"""
import csv

import numpy as np

LATERAL_BANDS = range(-6, 6, 2)  # mm, each 2 mm wide
DEPTH_BANDS = (3.0, 3.5, 4.0, 4.5)  # mm, each 0.5 mm wide


def read(path):
    """The labels read by the simulator-trained network, in the file's order, `col(name)`, that
    column as an array, and `has(name)`, whether the file has that column."""
    rows = list(csv.DictReader(open(path)))
    labels = [c[: -len("_sim_trained")] for c in rows[0] if c.endswith("_sim_trained")]
    return labels, lambda name: np.array([float(r[name]) for r in rows]), lambda name: name in rows[0]


def band_table(y, z, cell):
    """One row per lateral band: its name and `cell(mask)` for each depth band's taps."""
    return [(f"{lo:+d}..{lo + 2:+d} mm", [cell((y >= lo) & (y < lo + 2) & (z >= a) & (z < a + 0.5)) for a in DEPTH_BANDS])
            for lo in LATERAL_BANDS]


def depth_header():
    return [f"{a:.1f}-{a + 0.5:.1f}" for a in DEPTH_BANDS]
