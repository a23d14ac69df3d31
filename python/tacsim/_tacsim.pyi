"""Type stubs of the extension module (units: mm, deg, N, MPa)."""

from typing import Callable, Optional, Sequence, Tuple

import numpy as np
import numpy.typing as npt

Pose = Sequence[float]
"""(x_mm, y_mm, depth_mm, yaw_deg) or (x_mm, y_mm, depth_mm, yaw_deg, rx_deg, ry_deg)."""

def shapes() -> list[str]:
    """The built-in stimuli's names (disk, square, clover, ...)."""

def slide_many(
    contacts: Sequence["Contact"],
    poses: Sequence[Pose],
    step_mm: float = 0.25,
    step_deg: float = 5.0,
    size: Optional[int] = None,
) -> npt.NDArray[np.uint8]:
    """Slides each (distinct) contact to its pose on all cores, GIL released; their images
    (n, size, size). Each result equals Contact.slide_to then Contact.image alone."""

def generate(
    recipe: str,
    out: str,
    sensor: Optional[str] = None,
    seed: Optional[int] = None,
    size: Optional[int] = None,
    cells: Optional[int] = None,
    threads: Optional[int] = None,
    resume: bool = False,
    force: bool = False,
    progress: Optional[Callable[[int, int], None]] = None,
    shard: Optional[Tuple[int, int]] = None,
) -> dict:
    """The dataset of a recipe (file or built-in name) into out, as `tacsim generate` writes it
    (same bytes for a seed); progress(done, total) about 100 times; returns the summary
    (images, written, skipped, rewritten, no_contact, wall_s). More than 1,000,000 images or
    about 16 GiB need force=True. shard=(i, n): shard i of n (from 0), joined by merge."""

def plan(
    recipe: str,
    sensor: Optional[str] = None,
    seed: Optional[int] = None,
    size: Optional[int] = None,
    cells: Optional[int] = None,
    force: bool = False,
    shard: Optional[Tuple[int, int]] = None,
) -> int:
    """The images generate would make for these arguments (a shard's with shard), after every
    check it makes before writing; nothing simulated or written."""

def merge(out: str, shards: Sequence[str], move: bool = False) -> int:
    """Joins the shards of one recipe (every i of n once) into out, as `tacsim merge` does:
    each checked against its SHA256SUMS first; the bytes of the unsharded run. move=True
    renames each checked image into out instead of copying it (the shards lose their images).
    Returns the images merged."""

class Sensor:
    """A TacTip: dome, skin, pins, camera."""

    @staticmethod
    def load(name_or_path: Optional[str] = None) -> "Sensor":
        """A built-in preset or a sensor TOML file (default: the calibrated TacTip)."""
    @staticmethod
    def presets() -> list[str]:
        """The built-in preset names."""
    @property
    def name(self) -> str: ...
    @property
    def pin_count(self) -> int: ...
    @property
    def image_size(self) -> int:
        """The camera's image size (px)."""
    @property
    def dome_radius_mm(self) -> float: ...
    def to_toml(self) -> str:
        """The sensor in the TOML format of sim/presets/*.toml."""
    def undeformed_image(self, size: Optional[int] = None) -> npt.NDArray[np.uint8]:
        """The undeformed binary image, (size, size), 0 or 255."""

class Scene:
    """Stimuli placed in the world."""

    def __init__(
        self,
        shape: Optional[str] = None,
        obj_path: Optional[str] = None,
        pose: Tuple[float, float, float] = (0.0, 0.0, 0.0),
        friction: Optional[float] = None,
    ) -> None:
        """One stimulus (a built-in shape or an OBJ file) at pose (x_mm, y_mm, yaw_deg);
        friction in [0, 2] overrides the catalogue's (0.5 for a file)."""
    def add(
        self,
        shape: Optional[str] = None,
        obj_path: Optional[str] = None,
        pose: Tuple[float, float, float] = (0.0, 0.0, 0.0),
        friction: Optional[float] = None,
    ) -> None:
        """Adds a stimulus (as the constructor)."""
    @property
    def names(self) -> list[str]: ...
    def contact_mm(self, i: int) -> Optional[Tuple[float, float]]:
        """Stimulus i's catalogue contact point on its edge (mm, object frame)."""
    def edge(
        self, x_mm: float, y_mm: float, i: int = 0
    ) -> Tuple[float, Tuple[float, float], Tuple[float, float]]:
        """Stimulus i's edge nearest (x_mm, y_mm): (signed distance (mm, negative inside the
        material), nearest point, unit tangent with the material on its left)."""
    def contour(self, i: int = 0) -> list[npt.NDArray[np.float64]]:
        """Stimulus i's top-face contour loops in the world, each (n, 2) (mm)."""

class Contact:
    """The sensor over a scene, with stick/slip history. The GIL is released while it solves."""

    def __init__(self, sensor: Sensor, scene: Scene, max_depth_mm: float = 5.0, cells: Optional[int] = None) -> None:
        """Contact is solved on a grid of cells x cells (default: the sensor's skin.cells_across)
        holding every untilted contact up to max_depth_mm: set it near the deepest press."""
    def press(self, pose: Pose) -> None:
        """Lifts off (history cleared) and presses straight onto pose."""
    def slide_to(self, pose: Pose, step_mm: float = 0.25, step_deg: float = 5.0) -> None:
        """Slides from the current pose to pose in steps of at most step_mm / step_deg."""
    def lift(self) -> None:
        """No contact, no history."""
    @property
    def pose(self) -> Optional[Tuple[float, float, float, float, float, float]]: ...
    @property
    def in_contact(self) -> bool: ...
    @property
    def force_n(self) -> npt.NDArray[np.float64]:
        """Total force on the skin, sensor frame (N): shear x, y and normal (pressing)."""
    @property
    def contact_cells(self) -> Tuple[int, int]:
        """(cells in contact, cells slipping) at the last step."""
    def image(self, size: Optional[int] = None) -> npt.NDArray[np.uint8]:
        """The binary pin image, (size, size), 0 or 255."""
    def pins_px(self, size: Optional[int] = None) -> npt.NDArray[np.float64]:
        """Pin tip centres in the image, (n, 2): u right, v down (px); nan if unseen."""
    def pins_mm(self) -> npt.NDArray[np.float64]:
        """Pin tip centres in the sensor frame, (n, 3) (mm)."""
    def pressure(self) -> Tuple[npt.NDArray[np.float64], float]:
        """The contact pressure (MPa) on the grid, (ny, nx), and the cell side (mm)."""

class Dataset:
    """A dataset written by `tacsim generate`."""

    def __init__(self, dir: str) -> None: ...
    def __len__(self) -> int: ...
    @property
    def columns(self) -> list[str]:
        """The 12 label columns (pose_x .. shear_Rz; mm, deg)."""
    @property
    def image_size(self) -> int: ...
    def samples(
        self, split_name: str = "train", kind_name: str = "tap", subset_name: str = "all"
    ) -> Tuple[npt.NDArray[np.uint8], npt.NDArray[np.float64]]:
        """(images (n, s, s), labels (n, 12)) of one split (train/val/test), kind (tap/slide)
        and subset (all/paired/unpaired)."""
    def true_pairs(
        self, split_name: str = "train", subset_name: str = "all"
    ) -> Tuple[
        npt.NDArray[np.uint8], npt.NDArray[np.uint8], npt.NDArray[np.float64], npt.NDArray[np.float64]
    ]:
        """(tap images, slide images, tap labels, slide labels) of the true pairs."""
    def reference(self) -> npt.NDArray[np.uint8]:
        """The undeformed reference image."""
