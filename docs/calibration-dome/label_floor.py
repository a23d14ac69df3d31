"""How much of the surface fit's error a smooth function of the recordings' labels could take.

Reads a `cargo xtask real-compare --dump FILE` of the surface recordings. The labels: depth,
the two tilts and the slide's x, y and twist, each standardised. Five folds of the recordings
(a seeded shuffle); on each, fitted on the other four (ridge least squares on the monomials of
the labels up to a degree) and scored on it with the fit's relative error (mean pin error over
mean real motion):
- the lab's pin motion predicted from the labels alone (what the recordings tell of each other);
- the simulated motion plus a correction in the labels fitted to what the simulator misses
  (what any change to the simulator whose effect is that smooth in the labels could take at
  most, learnt from 480 recordings);
- the real global shift (the median pin motion) from the labels, against the simulator's.
Needs numpy.

    python3 docs/calibration-dome/label_floor.py WORK/dump.json
"""

import itertools
import json
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from error_parts import DEPTHS, field  # noqa: E402

FOLDS = 5


def basis(z, degree):
    cols = [np.ones(len(z))]
    for k in range(1, degree + 1):
        cols += [np.prod(z[:, c], axis=1) for c in itertools.combinations_with_replacement(range(z.shape[1]), k)]
    return np.stack(cols, axis=1)


def cross_fitted(b, target, ridge, folds):
    """Each fold's rows of `b @ coef`, `coef` fitted on the other folds."""
    out = np.zeros_like(target)
    for f in range(FOLDS):
        fit, held = folds != f, folds == f
        a = b[fit]
        out[held] = b[held] @ np.linalg.solve(a.T @ a + ridge * np.eye(b.shape[1]), a.T @ target[fit])
    return out


def main(path):
    samples = json.load(open(path))["samples"]
    labels = np.array([[s["pose"][2], s["pose"][3], s["pose"][4], s["shear"][0], s["shear"][1], s["shear"][5]]
                       for s in samples])
    z = (labels - labels.mean(axis=0)) / labels.std(axis=0)
    real = np.stack([field(s["real"]) for s in samples])
    sim = np.stack([field(s["sim"]) for s in samples])
    ok = ~np.isnan(real).any(axis=2) & ~np.isnan(sim).any(axis=2)
    n = len(samples)
    folds = np.random.default_rng(0).permutation(n) % FOLDS
    flat_real = np.where(ok[:, :, None], real, 0.0).reshape(n, -1)
    flat_sim = np.where(ok[:, :, None], sim, 0.0).reshape(n, -1)
    depth = labels[:, 0]

    def score(pred):
        pred = pred.reshape(real.shape)
        e = np.array([np.linalg.norm(pred[i][ok[i]] - real[i][ok[i]], axis=1).mean()
                      / np.linalg.norm(real[i][ok[i]], axis=1).mean() for i in range(n)])
        bands = " / ".join("%.3f" % e[(depth >= lo) & (depth < hi)].mean() for lo, hi in DEPTHS)
        return "%.3f (by depth %s)" % (e.mean(), bands)

    print(f"{n} recordings, {FOLDS} folds; relative error on the held-out fold")
    print("simulator as replayed:", score(flat_sim))
    for degree, ridge in ((2, 1.0), (3, 10.0), (4, 10.0)):
        print(f"the lab's motion from the labels, degree {degree}, ridge {ridge:g}:",
              score(cross_fitted(basis(z, degree), flat_real, ridge, folds)))
    for degree, ridge in ((1, 100.0), (2, 100.0), (3, 100.0), (3, 300.0), (3, 1000.0), (4, 1000.0)):
        fix = cross_fitted(basis(z, degree), flat_real - flat_sim, ridge, folds)
        print(f"simulator + a correction in the labels, degree {degree}, ridge {ridge:g}:", score(flat_sim + fix))
    for name, cols in (("depth", [0]), ("depth and tilts", [0, 1, 2]), ("slides", [3, 4, 5])):
        fix = cross_fitted(basis(z[:, cols], 3), flat_real - flat_sim, 300.0, folds)
        print(f"  the same, degree 3, ridge 300, in the {name} alone:", score(flat_sim + fix))
    shift_real = np.array([np.median(real[i][ok[i]], axis=0) for i in range(n)])
    shift_sim = np.array([np.median(sim[i][ok[i]], axis=0) for i in range(n)])
    rms = lambda d: np.sqrt((d ** 2).sum(axis=1).mean())  # noqa: E731
    print("global shift: rms %.2f px; the simulator's error %.2f px" % (rms(shift_real), rms(shift_sim - shift_real)))
    for degree in (1, 2, 3):
        pred = cross_fitted(basis(z, degree), shift_real, 1.0, folds)
        print(f"  from the labels, degree {degree}: error {rms(pred - shift_real):.2f} px")


if __name__ == "__main__":
    main(sys.argv[1])
