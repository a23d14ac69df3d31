"""The tangential solver on the dome's problems: its spectrum and three ways to precondition it.

Reads the problems that `dump.patch` writes (one JSON line per tangential solve: the contact
cells' dense matrix `A_t`, the slip offset `b`, the bounds `mu p`, the warm start, the solver's
iterations and tolerance), replays the solver's projected heavy ball (`minimise` in
`sim/src/contact/solve/tangential.rs`, in float64 on the f32 matrix's values) and checks that
it takes the same iterations (within one: the solver's products are in f32), then counts the iterations of:

- `deflated`: before every step, the exact minimiser over the top-k eigenvectors restricted to
  the cells inside their bound (a coarse correction; the step stays the heavy ball's);
- `scaled`: the heavy ball on the gradient with the top-k eigenvalues scaled down to the
  (k+1)-th (a preconditioner with the per-cell projection kept Euclidean);
- `two-metric`: the same scaling on the cells inside their bound only (Bertsekas' two-metric
  projection), the cells on their bound taking the plain gradient.

Usage (numpy needed):

    git apply docs/experiments/shear-solver/dump.patch && cargo build --release
    RAYON_NUM_THREADS=1 TACSIM_DUMP_SHEAR=WORK/shear.jsonl \
        target/release/tacsim bench --skin dome --samples 4 --plot WORK/b.svg
    python3 docs/experiments/shear-solver/study.py WORK/shear.jsonl 40
    git apply -R docs/experiments/shear-solver/dump.patch
"""

import json
import sys

import numpy as np

UPHILL_WINDOW = 5
MAX_CONDITION = 1e4


def project(qx, qy, r):
    n = np.hypot(qx, qy)
    s = np.where(n <= r, 1.0, np.where(r <= 0, 0.0, r / np.maximum(n, 1e-300)))
    return qx * s, qy * s


def residual(q, g, bound, local, m):
    jx, jy = project(q[:m] - local * g[:m], q[m:] - local * g[m:], bound)
    return np.hypot(jx - q[:m], jy - q[m:]).sum() / bound.sum()


class Problem:
    def __init__(self, d):
        self.m = m = d["m"]
        self.A = np.array(d["A"]).reshape(2 * m, 2 * m)
        self.b = np.array(d["b"])
        self.bound = np.array(d["bound"])
        self.start = np.array(d["start"])
        self.l, self.checker, self.local = d["l"], d["checker"], 1.0 / d["local"]
        self.tolerance, self.iterations = d["tolerance"], d["iters"]
        w, U = np.linalg.eigh(0.5 * (self.A + self.A.T))
        self.eigenvalues, self.eigenvectors = w, U

    def objective(self, q):
        return q @ (0.5 * (self.A @ q) + self.b)

    def inside(self, q, g=None, eps=1e-3):
        """Cells strictly inside their bound (or, given `g`, not pushed out of it)."""
        m = self.m
        on = np.hypot(q[:m], q[m:]) >= self.bound * (1 - eps)
        if g is not None:
            on &= (q[:m] * g[:m] + q[m:] * g[m:]) < 0
        return np.concatenate([~on, ~on]).astype(float)


def heavy_ball(p, direction=None, lipschitz=None, correction=None, limit=3000):
    """The solver's projected heavy ball with restart and the non-monotone rule; `direction`
    maps (q, g) to the step's direction (default g), `correction` maps q to a better q."""
    m = p.m
    l = p.l if lipschitz is None else lipschitz
    lowest = min(max(p.checker, l / MAX_CONDITION), l)
    a, c = np.sqrt(l), np.sqrt(lowest)
    step, momentum = 4 / (a + c) ** 2, ((a - c) / (a + c)) ** 2
    direction = direction or (lambda q, g: g)

    def projected(frm, d, st):
        x, y = project(frm[:m] - st * d[:m], frm[m:] - st * d[m:], p.bound)
        return np.concatenate([x, y])

    x, y = project(p.start[:m], p.start[m:], p.bound)
    q = np.concatenate([x, y])
    prev = q.copy()
    recent, accepted, carried = [np.inf] * UPHILL_WINDOW, 0, False
    for iteration in range(1, limit + 1):
        if correction is not None:
            corrected = correction(q)
            prev, q = prev + (corrected - q), corrected
        g = p.A @ q + p.b
        value = p.objective(q)
        if carried and value >= max(recent):
            q, prev = prev, q
            g = p.A @ q + p.b
            nxt = projected(q, direction(q, g), 1 / l)
            prev, q, carried = q.copy(), nxt, False
            continue
        nxt = projected(q + momentum * (q - prev), direction(q, g), step)
        if residual(q, g, p.bound, p.local, m) < p.tolerance:
            return iteration
        carried = momentum > 0
        if carried and g @ (nxt - q) > 0:
            nxt = projected(q, direction(q, g), 1 / l)
            carried = False
        recent[accepted % UPHILL_WINDOW] = value
        accepted += 1
        prev, q = q, nxt
    return limit


def deflated(p, k):
    V = p.eigenvectors[:, -k:]

    def correction(q):
        m = p.m
        g = p.A @ q + p.b
        VF = V * p.inside(q)[:, None]
        dq = VF @ -np.linalg.solve(VF.T @ p.A @ VF, VF.T @ g)
        x, y, dx, dy = q[:m], q[m:], dq[:m], dq[m:]
        aa, bb, cc = dx * dx + dy * dy, 2 * (x * dx + y * dy), x * x + y * y - p.bound**2
        with np.errstate(all="ignore"):
            reach = np.where(aa > 0, (-bb + np.sqrt(np.maximum(bb * bb - 4 * aa * cc, 0))) / (2 * aa), np.inf)
        free = p.inside(q)[:m] > 0
        t = min(1.0, reach[free].min()) if free.any() else 1.0
        return q + t * dq

    return heavy_ball(p, correction=correction)


def scaled(p, k, two_metric):
    V, lam = p.eigenvectors[:, -k:], p.eigenvalues[-k:]
    lower = 1.02 * p.eigenvalues[-k - 1]
    scale = lower / lam - 1

    def direction(q, g):
        if not two_metric:
            return g + V @ (scale * (V.T @ g))
        free = p.inside(q, g)
        return free * (g + V @ (scale * (V.T @ (g * free)))) + (1 - free) * g * (lower / p.l)

    return heavy_ball(p, direction=direction, lipschitz=lower)


def main():
    path, count = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 40
    with open(path) as f:
        problems = [Problem(json.loads(line)) for _, line in zip(range(count), f)]
    replay = [heavy_ball(p) for p in problems]
    solver = [p.iterations for p in problems]
    off = sum(abs(a - b) > 1 for a, b in zip(replay, solver))
    print(f"{len(problems)} solves; the solver's iterations {sum(solver)}, replayed {sum(replay)}")
    # The solver's products are in f32 and these in f64: a solve may stop one iteration apart.
    assert off == 0, f"{off} solves replayed more than one iteration apart"
    p = problems[0]
    w = p.eigenvalues
    print(
        f"first solve, {p.m} cells: eigenvalues {w[0]:.3f} .. {w[-1]:.1f} mm/MPa "
        f"(condition {w[-1] / w[0]:.0f}), median {np.median(w):.2f}, top ten {np.round(w[-10:][::-1], 1)}"
    )
    print("variant       k  iterations (all solves)  solves not converged in 3,000")
    for name, run in [
        ("deflated", lambda p, k: deflated(p, k)),
        ("scaled", lambda p, k: scaled(p, k, False)),
        ("two-metric", lambda p, k: scaled(p, k, True)),
    ]:
        for k in [2, 4, 6, 12]:
            its = [run(p, k) for p in problems]
            print(f"{name:12s} {k:2d}  {sum(its):23d}  {sum(i >= 3000 for i in its)}")


if __name__ == "__main__":
    main()
