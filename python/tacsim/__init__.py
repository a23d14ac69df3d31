"""tacsim: a physics-simulated TacTip (331 pins on a soft skin, camera inside).

The sensor is pressed and slid over mesh stimuli with frictional elastic contact and
stick/slip history; the camera's binarised pin images, the pins, the contact pressure and
the force come back as numpy arrays. Units: mm, deg, N, MPa. Frames: a sensor pose is
``(x_mm, y_mm, depth_mm, yaw_deg[, rx_deg, ry_deg])`` in the world (the stimuli's frame,
depth below the highest top face); pins and forces are in the sensor frame (``z`` along
its axis, pressing); image ``u`` runs right and ``v`` down (px).

>>> import tacsim
>>> contact = tacsim.Contact(tacsim.Sensor.load(), tacsim.Scene("square"))
>>> contact.press((45.0, 0.0, 1.5, 0.0))        # on the square's right edge
>>> contact.slide_to((45.0, 2.0, 1.5, 0.0))     # 2 mm along it, stick/slip kept
>>> contact.image(128).shape
(128, 128)
"""

from ._tacsim import Contact, Dataset, Scene, Sensor, generate, merge, plan, shapes, slide_many
from .sim2real import sim2real

__all__ = ["Contact", "Dataset", "Scene", "Sensor", "generate", "merge", "plan", "shapes", "sim2real", "slide_many"]

try:  # The environments need gymnasium (pip install gymnasium); the engine does not.
    import gymnasium as _gymnasium  # noqa: F401
except ImportError:
    pass
else:
    from .envs import register as _register

    _register()
