"""`tacsim/EdgeFollow-v0`: trace a stimulus's edge with the TacTip, as `tacsim run` does.

The sensor slides along the edge at a fixed depth, with the material on its left (its +x is
the direction of travel); every move is solved by the contact engine with stick/slip history.
Each step the policy gives the servo's corrections, normalised to [-1, 1]:

- ``action[0]``: lateral move (x ``max_lateral_mm``), positive off the material;
- ``action[1]``: turn (x ``max_turn_deg``), positive counter-clockwise;
- ``action[2]``: forward step, ``(a + 1) / 2 x max_step_mm`` along the sensor's x.

Observation (``obs_type``): ``"image"``, the binary pin image ``uint8 (size, size, 1)``;
``"pins"``, the pins' displacement from the undeformed sensor in the image, ``float32
(n, 2)`` px; or ``"both"`` (a dict). Reward: progress along the contour (mm) minus
``deviation_weight`` x the distance of the sensor's axis from the edge (mm). The episode
ends (terminated) when the loop closes or the sensor leaves the edge by more than
``max_deviation_mm``; ``max_episode_steps`` truncates it. ``shape`` is a built-in name, or a
list of them: each ``reset`` then draws one from the environment's generator (a policy
trained over several stimuli). Options of ``reset``: ``shape`` (a built-in name), ``obj_path``,
``start_mm`` (a point near the edge; default: a random point of the contour drawn from the
seed). ``sensor`` (a ``tacsim.Sensor``, a preset name or a sensor file) defaults to
``tactip-331-calibrated``, the calibrated TacTip over a half-space: along a sharp edge its pins
are within 0.03 mm of a fine contact grid at the sensor's cells, where the default dome's
need 49 (``docs/guide/fem.md``, "The contact grid").
"""

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

import tacsim

from .contour import Contour


class EdgeFollowEnv(gym.Env):
    """Contour following on a catalogue shape or an OBJ (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        shape="square",
        obj_path=None,
        sensor="tactip-331-calibrated",
        depth_mm=1.5,
        image_size=128,
        obs_type="image",
        max_step_mm=2.0,
        max_lateral_mm=1.0,
        max_turn_deg=10.0,
        substep_mm=0.5,
        deviation_weight=0.5,
        max_deviation_mm=5.0,
        render_mode=None,
    ):
        if obs_type not in ("image", "pins", "both"):
            raise ValueError(f"obs_type must be image, pins or both, got {obs_type!r}")
        if not 0.0 < depth_mm <= 5.0:
            raise ValueError(f"depth_mm must be in (0, 5] mm, got {depth_mm}")
        if not 0.0 < max_step_mm <= 10.0:
            raise ValueError(f"max_step_mm must be in (0, 10] mm, got {max_step_mm}")
        self.sensor = sensor if isinstance(sensor, tacsim.Sensor) else tacsim.Sensor.load(sensor)
        self.depth_mm, self.size, self.obs_type = float(depth_mm), int(image_size), obs_type
        self.max_step_mm, self.max_lateral_mm, self.max_turn_deg = max_step_mm, max_lateral_mm, max_turn_deg
        self.substep_mm, self.deviation_weight, self.max_deviation_mm = substep_mm, deviation_weight, max_deviation_mm
        self.render_mode = render_mode
        if isinstance(shape, (list, tuple)):
            if not shape or not all(isinstance(name, str) for name in shape):
                raise ValueError(f"shape must be a built-in name or a non-empty list of them, got {shape!r}")
            self._shapes = list(shape)
            shape = self._shapes[0]
        else:
            self._shapes = None
        self._shape, self._obj_path = shape, obj_path
        self._load(shape, obj_path)
        n = self.sensor.pin_count
        image = spaces.Box(0, 255, (self.size, self.size, 1), np.uint8)
        pins = spaces.Box(-np.inf, np.inf, (n, 2), np.float32)
        self.observation_space = {"image": image, "pins": pins, "both": spaces.Dict({"image": image, "pins": pins})}[
            obs_type
        ]
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)

    def _load(self, shape, obj_path):
        self.scene = tacsim.Scene(shape=None if obj_path else shape, obj_path=obj_path)
        loops = self.scene.contour(0)
        self.contour = Contour(max(loops, key=len))
        self.contact = tacsim.Contact(self.sensor, self.scene, max_depth_mm=self.depth_mm)
        self._undeformed = self.contact.pins_px(self.size)

    def _observe(self, image):
        obs = {}
        if self.obs_type in ("image", "both"):
            obs["image"] = image.reshape(self.size, self.size, 1)
        if self.obs_type in ("pins", "both"):
            obs["pins"] = np.nan_to_num(self.contact.pins_px(self.size) - self._undeformed).astype(np.float32)
        return obs[self.obs_type] if self.obs_type != "both" else obs

    def _deviation(self):
        x, y = self.pose[0], self.pose[1]
        return abs(self.scene.edge(x, y)[0])

    def _info(self):
        return {"pose": tuple(self.pose), "progress_mm": self.progress, "deviation_mm": self._deviation()}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        options = options or {}
        if "shape" in options or "obj_path" in options:
            self._load(options.get("shape", self._shape), options.get("obj_path"))
        elif self._shapes is not None and self._obj_path is None:
            name = self._shapes[int(self.np_random.integers(len(self._shapes)))]
            if self.scene.names != [name]:
                self._load(name, None)
        if "start_mm" in options:
            start = np.asarray(options["start_mm"], dtype=np.float64)
        else:
            start = self.contour.point_at(self.np_random.uniform(0.0, self.contour.perimeter))
        _, point, tangent = self.scene.edge(float(start[0]), float(start[1]))
        yaw = math.degrees(math.atan2(tangent[1], tangent[0]))
        self.pose = [point[0], point[1], self.depth_mm, yaw]
        # Touch down one step back along the edge and slide onto the start, so that the first
        # image carries the drag of sliding like every later one.
        back = [point[0] - self.max_step_mm * tangent[0], point[1] - self.max_step_mm * tangent[1], self.depth_mm, yaw]
        self.contact.press(back)
        self.contact.slide_to(self.pose, step_mm=self.substep_mm, step_deg=2.0)
        self.s = self.contour.arc_position(point)
        self.progress = 0.0
        self._image = self.contact.image(self.size)
        return self._observe(self._image), self._info()

    def target(self, action):
        """The pose the servo moves to for ``action`` (see the module docstring)."""
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        x, y, depth, yaw = self.pose
        yaw_new = yaw + a[1] * self.max_turn_deg
        t = math.radians(yaw_new)
        step = 0.5 * (a[2] + 1.0) * self.max_step_mm
        lateral = a[0] * self.max_lateral_mm
        # Off the material is to the right of travel: (sin t, -cos t).
        return [x + step * math.cos(t) + lateral * math.sin(t), y + step * math.sin(t) - lateral * math.cos(t), depth, yaw_new]

    def finish_step(self, target, image):
        """Bookkeeping after the contact reached ``target``: observation, reward, ends, info."""
        self.pose = list(target)
        self._image = image
        s = self.contour.arc_position(self.pose[:2])
        ds = self.contour.advance(self.s, s)
        self.s, self.progress = s, self.progress + ds
        deviation = self._deviation()
        reward = ds - self.deviation_weight * deviation
        closed = self.progress >= self.contour.perimeter - 0.5 * self.max_step_mm
        lost = deviation > self.max_deviation_mm
        info = self._info()
        info.update(closed=closed, lost=lost)
        return self._observe(image), float(reward), bool(closed or lost), False, info

    def step(self, action):
        target = self.target(action)
        self.contact.slide_to(target, step_mm=self.substep_mm, step_deg=2.0)
        return self.finish_step(target, self.contact.image(self.size))

    def render(self):
        if self.render_mode == "rgb_array":
            return np.repeat(self._image[:, :, None], 3, axis=2)
        return None

    def servo_action(self, kp_lateral=0.8, kp_turn=1.0):
        """An oracle servo's action (the true edge pose): a baseline policy and a test aid.
        It slows down where the edge turns away (corners) so as not to lose it."""
        x, y, _, yaw = self.pose
        d, _, tangent = self.scene.edge(x, y)
        turn = math.degrees(math.atan2(tangent[1], tangent[0])) - yaw
        turn = (turn + 180.0) % 360.0 - 180.0
        speed = max(0.0, 1.0 - abs(turn) / 30.0)
        # d > 0 is off the material: move back on (negative lateral).
        a = [-kp_lateral * d / self.max_lateral_mm, kp_turn * turn / self.max_turn_deg, 2.0 * speed - 1.0]
        return np.clip(a, -1.0, 1.0).astype(np.float32)
