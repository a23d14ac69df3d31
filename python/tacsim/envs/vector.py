"""`EdgeFollowVectorEnv`: many EdgeFollow environments stepped in one call on all cores.

Each step solves every environment's slide and renders its image in Rust (rayon, the GIL
released: ``tacsim.slide_many``); the rest (servo targets, rewards) is numpy. Environment ``i``
is seeded ``seed + i`` and gives exactly what a single ``EdgeFollowEnv`` so seeded gives for
the same actions, whatever the thread count. Autoreset (``autoreset_mode``): ``"next_step"``
(gymnasium's default), an environment that ended is reset on the following ``step`` call, its
action ignored; or ``"same_step"``, reset in the step that ended it, whose observation is
then the new episode's first and ``infos["final_obs"]``, ``infos["final_info"]`` (with
``"_final_obs"``, ``"_final_info"`` masks) hold the ended one's last, as gymnasium's
``AutoresetMode.SAME_STEP`` (what Stable-Baselines3 expects; ``tacsim.envs.sb3``).
"""

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import batch_space

import tacsim

from .edge_follow import EdgeFollowEnv


def autoreset_mode_of(name):
    """Gymnasium's ``AutoresetMode`` named ``"next_step"`` or ``"same_step"``."""
    modes = {"next_step": gym.vector.AutoresetMode.NEXT_STEP, "same_step": gym.vector.AutoresetMode.SAME_STEP}
    if name not in modes:
        raise ValueError(f"autoreset_mode must be next_step or same_step, got {name!r}")
    return modes[name]


class EdgeFollowVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` EdgeFollow environments (keyword arguments as ``EdgeFollowEnv``)."""

    metadata = {"autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs=4, max_episode_steps=500, autoreset_mode="next_step", **kwargs):
        if num_envs < 1:
            raise ValueError(f"num_envs must be at least 1, got {num_envs}")
        self.metadata = {**self.metadata, "autoreset_mode": autoreset_mode_of(autoreset_mode)}
        self._same_step = autoreset_mode == "same_step"
        self.envs = [EdgeFollowEnv(**kwargs) for _ in range(num_envs)]
        self.num_envs = num_envs
        self.max_episode_steps = int(max_episode_steps)
        self.single_observation_space = self.envs[0].observation_space
        self.single_action_space = self.envs[0].action_space
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._ended = np.zeros(num_envs, dtype=bool)
        self._steps = np.zeros(num_envs, dtype=np.int64)

    def _batch(self, observations):
        if isinstance(self.single_observation_space, gym.spaces.Dict):
            return {k: np.stack([o[k] for o in observations]) for k in observations[0]}
        return np.stack(observations)

    @staticmethod
    def _infos(infos):
        keys = {k for i in infos for k in i if k != "pose"}
        out = {}
        for k in sorted(keys):
            out[k] = np.array([i.get(k, 0) for i in infos])
            out["_" + k] = np.array([k in i for i in infos])
        return out

    def reset(self, *, seed=None, options=None):
        seeds = [None] * self.num_envs if seed is None else [seed + i for i in range(self.num_envs)]
        results = [env.reset(seed=s, options=options) for env, s in zip(self.envs, seeds)]
        self._ended[:] = False
        self._steps[:] = 0
        return self._batch([o for o, _ in results]), self._infos([i for _, i in results])

    def step(self, actions):
        actions = np.asarray(actions)
        live = [i for i in range(self.num_envs) if not self._ended[i]]
        targets = [self.envs[i].target(actions[i]) for i in live]
        size = self.envs[0].size
        step_mm = self.envs[0].substep_mm
        images = (
            tacsim.slide_many([self.envs[i].contact for i in live], targets, step_mm=step_mm, step_deg=2.0, size=size)
            if live
            else []
        )
        obs, rewards = [None] * self.num_envs, np.zeros(self.num_envs)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        infos = [{} for _ in range(self.num_envs)]
        for k, i in enumerate(live):
            obs[i], rewards[i], terminated[i], _, infos[i] = self.envs[i].finish_step(targets[k], images[k])
            self._steps[i] += 1
            truncated[i] = not terminated[i] and self._steps[i] >= self.max_episode_steps
        if self._same_step:
            ended = terminated | truncated
            final_obs, final_info = [None] * self.num_envs, [None] * self.num_envs
            for i in np.flatnonzero(ended):
                # The environment's own generator draws the new start.
                final_obs[i], final_info[i] = obs[i], infos[i]
                obs[i], infos[i] = self.envs[i].reset()
                self._steps[i] = 0
            out = self._infos(infos)
            if ended.any():
                out["final_obs"] = np.array(final_obs, dtype=object)
                out["_final_obs"] = ended.copy()
                out["final_info"] = np.array(final_info, dtype=object)
                out["_final_info"] = ended.copy()
            return self._batch(obs), rewards, terminated, truncated, out
        for i in range(self.num_envs):
            if self._ended[i]:
                # Next-step autoreset: the environment's own generator draws the new start.
                obs[i], infos[i] = self.envs[i].reset()
                self._steps[i] = 0
        self._ended = terminated | truncated
        return self._batch(obs), rewards, terminated, truncated, self._infos(infos)
