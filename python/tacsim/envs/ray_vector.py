"""`RayEdgeFollowVectorEnv`: EdgeFollow environments spread over Ray actors, in Gymnasium's
vector API.

``num_envs`` environments are cut into ``actors`` contiguous slices; each actor holds one slice
as an ``EdgeFollowVectorEnv`` (the Rust vector env: every slide of its slice in one call on its
node's cores) and the driver sends each actor its slice of the actions and joins the results.
Environment ``i`` is seeded ``seed + i`` as in the local vector env, and each actor autoresets
its own environments the same way (``autoreset_mode``, as the local one's), so the two give the
same observations, rewards and ends for the same seeds and actions. Needs the ``ray`` extra
(``pip install './python[ray]'``); connects to ``address`` or starts a local cluster where Ray is
not initialised.
"""

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import batch_space

from .vector import autoreset_mode_of


def _ray():
    from tacsim.ray import _ray as ray_module

    return ray_module()


def _actor_class(ray, cpus):
    @ray.remote(num_cpus=cpus)
    class EnvSlice:
        def __init__(self, num_envs, max_episode_steps, autoreset_mode, kwargs):
            from tacsim.envs.vector import EdgeFollowVectorEnv

            self.env = EdgeFollowVectorEnv(
                num_envs=num_envs, max_episode_steps=max_episode_steps, autoreset_mode=autoreset_mode, **kwargs
            )

        def spaces(self):
            return self.env.single_observation_space, self.env.single_action_space

        def reset(self, seed, options):
            return self.env.reset(seed=seed, options=options)

        def step(self, actions):
            return self.env.step(actions)

    return EnvSlice


class RayEdgeFollowVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` EdgeFollow environments over ``actors`` Ray actors (default: one per alive
    node, at most ``num_envs``), each asking ``cpus_per_actor`` CPUs (default 1); keyword
    arguments as ``EdgeFollowEnv``."""

    metadata = {"autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs=4,
        actors=None,
        address=None,
        cpus_per_actor=1,
        max_episode_steps=500,
        autoreset_mode="next_step",
        **kwargs,
    ):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a whole number of at least 1, got {num_envs!r}")
        if actors is not None and (isinstance(actors, bool) or not isinstance(actors, int) or not 1 <= actors <= num_envs):
            raise ValueError(f"actors must be a whole number in [1, num_envs = {num_envs}], got {actors!r}")
        if isinstance(cpus_per_actor, bool) or not isinstance(cpus_per_actor, (int, float)) or not cpus_per_actor > 0:
            raise ValueError(f"cpus_per_actor must be a positive number, got {cpus_per_actor!r}")
        self.metadata = {**self.metadata, "autoreset_mode": autoreset_mode_of(autoreset_mode)}
        ray = _ray()
        if not ray.is_initialized():
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        if actors is None:
            actors = max(1, min(num_envs, sum(1 for n in ray.nodes() if n.get("Alive"))))
        self.num_envs = num_envs
        # Slice k holds environments [starts[k], starts[k + 1]).
        base, extra = divmod(num_envs, actors)
        sizes = [base + (1 if k < extra else 0) for k in range(actors)]
        self._starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)
        cls = _actor_class(ray, cpus_per_actor)
        self._ray = ray
        self._actors = [cls.remote(n, int(max_episode_steps), autoreset_mode, kwargs) for n in sizes]
        self.single_observation_space, self.single_action_space = ray.get(self._actors[0].spaces.remote())
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)

    def _slices(self):
        return zip(self._actors, self._starts[:-1], self._starts[1:])

    def _join(self, parts):
        first = parts[0]
        if isinstance(first, dict) and isinstance(self.single_observation_space, gym.spaces.Dict):
            return {k: np.concatenate([p[k] for p in parts]) for k in first}
        return np.concatenate(parts)

    def _join_infos(self, infos):
        """The slices' info dicts as one: each key's values and its ``_key`` mask, an
        environment of a slice without the key marked absent (as the local env does)."""
        keys = sorted({k for i in infos for k in i if not k.startswith("_")})
        out = {}
        for k in keys:
            values, masks = [], []
            for info, (a, b) in zip(infos, zip(self._starts[:-1], self._starts[1:])):
                if k in info:
                    values.append(np.asarray(info[k]))
                    masks.append(np.asarray(info["_" + k]))
                else:
                    values.append(np.zeros(b - a))
                    masks.append(np.zeros(b - a, dtype=bool))
            out[k] = np.concatenate(values)
            out["_" + k] = np.concatenate(masks)
        return out

    def reset(self, *, seed=None, options=None):
        refs = [actor.reset.remote(None if seed is None else seed + int(a), options) for actor, a, _ in self._slices()]
        results = self._ray.get(refs)
        return self._join([o for o, _ in results]), self._join_infos([i for _, i in results])

    def step(self, actions):
        actions = np.asarray(actions)
        refs = [actor.step.remote(actions[a:b]) for actor, a, b in self._slices()]
        results = self._ray.get(refs)
        obs = self._join([r[0] for r in results])
        rewards, terminated, truncated = (np.concatenate([r[j] for r in results]) for j in (1, 2, 3))
        return obs, rewards, terminated, truncated, self._join_infos([r[4] for r in results])

    def close_extras(self, **kwargs):
        for actor in getattr(self, "_actors", []):
            self._ray.kill(actor)
        self._actors = []
