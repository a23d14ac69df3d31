"""`SB3VecEnv`: a Gymnasium vector environment of tacsim's (``EdgeFollowVectorEnv`` or
``RayEdgeFollowVectorEnv``, made with ``autoreset_mode="same_step"``) as Stable-Baselines3's
``VecEnv``, so that its algorithms (PPO, SAC, ...) step every environment in one call.

Stable-Baselines3 resets an environment in the step that ends it and keeps the last
observation in ``info["terminal_observation"]`` (and ``info["TimeLimit.truncated"]`` where
the episode was cut by the step limit): the same-step autoreset's ``final_obs``. Needs
``stable-baselines3`` (``pip install stable-baselines3``, with PyTorch).
"""

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


class SB3VecEnv(VecEnv):
    """Stable-Baselines3's view of ``vector_env`` (see the module docstring)."""

    def __init__(self, vector_env, seed=None):
        mode = vector_env.metadata.get("autoreset_mode")
        if getattr(mode, "name", str(mode)).upper() != "SAME_STEP":
            raise ValueError(f"make the vector env with autoreset_mode='same_step' (it has {mode})")
        self.venv = vector_env
        self._seed = seed
        self._actions = None
        super().__init__(vector_env.num_envs, vector_env.single_observation_space, vector_env.single_action_space)

    def reset(self):
        obs, infos = self.venv.reset(seed=self._seed)
        # A later reset draws on from the environments' generators.
        self._seed = None
        self.reset_infos = self._split(infos)
        return obs

    def step_async(self, actions):
        self._actions = np.asarray(actions)

    def step_wait(self):
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = terminated | truncated
        out = self._split(infos)
        for i in np.flatnonzero(dones):
            out[i] = dict(infos["final_info"][i])
            out[i]["terminal_observation"] = infos["final_obs"][i]
            out[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), dones, out

    def _split(self, infos):
        """Gymnasium's dict of arrays as Stable-Baselines3's list of dicts."""
        out = [{} for _ in range(self.num_envs)]
        for key, values in infos.items():
            if key.startswith("_") or key in ("final_obs", "final_info"):
                continue
            mask = infos.get("_" + key, np.ones(self.num_envs, dtype=bool))
            for i in np.flatnonzero(mask):
                out[i][key] = values[i]
        return out

    def close(self):
        self.venv.close()

    def seed(self, seed=None):
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def get_attr(self, attr_name, indices=None):
        return [getattr(self.venv, attr_name)] * len(self._indices(indices))

    def set_attr(self, attr_name, value, indices=None):
        raise AttributeError(f"cannot set {attr_name} on a tacsim vector env")

    def env_method(self, method_name, *args, indices=None, **kwargs):
        raise AttributeError(f"a tacsim vector env has no per-environment method {method_name}")

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False] * len(self._indices(indices))

    def _indices(self, indices):
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices
