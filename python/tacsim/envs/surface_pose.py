"""`tacsim/SurfacePose-v0`: press a tilted flat surface and estimate its pose from the image.

Each episode is one press: ``reset`` draws a depth in ``depth_mm`` and tilts ``rx``, ``ry``
in ``tilt_deg`` (uniform, from the seed), presses the sensor so tilted onto the top of the
built-in ``disk`` and observes the binary pin image ``uint8 (size, size, 1)``. The action is
the estimate ``(depth_mm, rx_deg, ry_deg)`` normalised to [-1, 1] over those ranges
(``pose_of`` and ``action_of`` convert); the reward is minus the error, each part over its
range's half-width (0 for a perfect estimate); the episode then ends. ``info["pose"]`` holds
the truth (mm, deg).
"""

import gymnasium as gym
import numpy as np
from gymnasium import spaces

import tacsim


class SurfacePoseEnv(gym.Env):
    """One press of a tilted surface per episode (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(self, sensor=None, image_size=128, depth_mm=(0.5, 2.5), tilt_deg=15.0, render_mode=None):
        lo, hi = depth_mm
        if not 0.0 < lo < hi <= 4.0:
            raise ValueError(f"depth_mm must satisfy 0 < low < high <= 4 mm, got {depth_mm}")
        if not 0.0 <= tilt_deg <= 25.0:
            raise ValueError(f"tilt_deg must be in [0, 25] deg, got {tilt_deg}")
        self.sensor = sensor if isinstance(sensor, tacsim.Sensor) else tacsim.Sensor.load(sensor)
        self.size, self.depth, self.tilt = int(image_size), (float(lo), float(hi)), float(tilt_deg)
        self.render_mode = render_mode
        # The grid is centred on the apex and holds untilted contacts up to max_depth_mm (its
        # half-side 1.1 sqrt(2 R max_depth)); a tilt moves the contact R sin(tilt) off the apex.
        r = self.sensor.dome_radius_mm
        half = r * np.sin(np.radians(self.tilt)) + 1.1 * np.sqrt(2.0 * r * hi)
        self.contact = tacsim.Contact(
            self.sensor, tacsim.Scene("disk"), max_depth_mm=min(0.5 * r, (half / 1.1) ** 2 / (2.0 * r))
        )
        self.observation_space = spaces.Box(0, 255, (self.size, self.size, 1), np.uint8)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self._mid = np.array([0.5 * (lo + hi), 0.0, 0.0])
        self._half = np.array([0.5 * (hi - lo), max(self.tilt, 1e-9), max(self.tilt, 1e-9)])
        self._image = np.zeros((self.size, self.size), np.uint8)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        depth = self.np_random.uniform(*self.depth)
        rx, ry = self.np_random.uniform(-self.tilt, self.tilt, size=2)
        self.truth = np.array([depth, rx, ry])
        self.contact.press((0.0, 0.0, depth, 0.0, rx, ry))
        self._image = self.contact.image(self.size)
        return self._image.reshape(self.size, self.size, 1), {"pose": tuple(self.truth)}

    def pose_of(self, action):
        """The estimate ``(depth_mm, rx_deg, ry_deg)`` an action stands for."""
        return self._mid + np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0) * self._half

    def action_of(self, pose):
        """The action that stands for ``(depth_mm, rx_deg, ry_deg)``."""
        return ((np.asarray(pose, dtype=np.float64) - self._mid) / self._half).astype(np.float32)

    def step(self, action):
        error = np.abs(self.pose_of(action) - self.truth)
        info = {"pose": tuple(self.truth), "error": tuple(error)}
        error = error / self._half
        return self._image.reshape(self.size, self.size, 1).copy(), -float(error.sum()), True, False, info

    def render(self):
        if self.render_mode == "rgb_array":
            return np.repeat(self._image[:, :, None], 3, axis=2)
        return None
