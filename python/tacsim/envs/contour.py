"""Arc-length positions along a closed contour (mm): progress of a sensor tracing an edge."""

import numpy as np


class Contour:
    """A closed polyline (float (n, 2), mm) with its cumulative arc length."""

    def __init__(self, points):
        self.points = np.asarray(points, dtype=np.float64)
        seg = np.roll(self.points, -1, axis=0) - self.points
        self.lengths = np.hypot(seg[:, 0], seg[:, 1])
        self.cumulative = np.concatenate([[0.0], np.cumsum(self.lengths)])
        self.perimeter = float(self.cumulative[-1])
        self._seg = seg

    def arc_position(self, p):
        """Arc length (mm) of the contour point nearest p = (x_mm, y_mm)."""
        a, d = self.points, self._seg
        len2 = np.maximum((d * d).sum(axis=1), 1e-300)
        t = np.clip(((p[0] - a[:, 0]) * d[:, 0] + (p[1] - a[:, 1]) * d[:, 1]) / len2, 0.0, 1.0)
        q = a + t[:, None] * d
        k = int(np.argmin((q[:, 0] - p[0]) ** 2 + (q[:, 1] - p[1]) ** 2))
        return float(self.cumulative[k] + t[k] * self.lengths[k])

    def point_at(self, s):
        """The contour point at arc length s (mm, wrapped)."""
        s = s % self.perimeter
        k = int(np.searchsorted(self.cumulative, s, side="right") - 1)
        k = min(k, len(self.points) - 1)
        t = (s - self.cumulative[k]) / max(self.lengths[k], 1e-300)
        return self.points[k] + t * self._seg[k]

    def advance(self, s_from, s_to):
        """Signed arc length (mm) from s_from to s_to, the short way round."""
        ds = s_to - s_from
        if ds > 0.5 * self.perimeter:
            ds -= self.perimeter
        elif ds < -0.5 * self.perimeter:
            ds += self.perimeter
        return ds
