"""Gymnasium environments on the tacsim engine, registered when `tacsim` is imported with
gymnasium installed: ``tacsim/EdgeFollow-v0`` (contour following, as `tacsim run`),
``tacsim/SurfacePose-v0`` (read a tilted surface's pose), ``EdgeFollowVectorEnv``
(``gymnasium.make_vec("tacsim/EdgeFollow-v0", num_envs=N, vectorization_mode="vector_entry_point")``)
and ``RayEdgeFollowVectorEnv`` (the same over Ray actors; the ``ray`` extra)."""

from .edge_follow import EdgeFollowEnv
from .surface_pose import SurfacePoseEnv
from .ray_vector import RayEdgeFollowVectorEnv
from .vector import EdgeFollowVectorEnv

__all__ = ["EdgeFollowEnv", "EdgeFollowVectorEnv", "RayEdgeFollowVectorEnv", "SurfacePoseEnv"]


def register():
    """Registers the environments with gymnasium (idempotent)."""
    import gymnasium as gym

    if "tacsim/EdgeFollow-v0" not in gym.registry:
        gym.register(
            id="tacsim/EdgeFollow-v0",
            entry_point="tacsim.envs.edge_follow:EdgeFollowEnv",
            vector_entry_point="tacsim.envs.vector:EdgeFollowVectorEnv",
            max_episode_steps=500,
        )
    if "tacsim/SurfacePose-v0" not in gym.registry:
        gym.register(id="tacsim/SurfacePose-v0", entry_point="tacsim.envs.surface_pose:SurfacePoseEnv")
