"""A policy learns on tacsim: a short Stable-Baselines3 PPO run on the edge-following vector env
(through ``tacsim.envs.sb3.SB3VecEnv``) returns more than a random policy, and the adapter
hands Stable-Baselines3 the same-step autoreset it expects.

Needs stable-baselines3 and PyTorch: skipped without them, saying so, and a failure under
CI=true, where the test venv installs them (tests/python.rs).
"""

import os

import numpy as np
import pytest

if os.environ.get("CI") == "true":
    import stable_baselines3  # noqa: F401 -- installed in CI: its absence fails the suite there
    import torch
else:
    pytest.importorskip("stable_baselines3", reason="pip install stable-baselines3 torch to test a policy on tacsim")
    torch = pytest.importorskip("torch", reason="pip install torch to test a policy on tacsim")

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize  # noqa: E402

from tacsim.envs import EdgeFollowEnv, EdgeFollowVectorEnv  # noqa: E402
from tacsim.envs.sb3 import SB3VecEnv  # noqa: E402

ENV = dict(shape="disk", obs_type="pins", image_size=128)


def episode_returns(act, episodes=4, steps=40):
    """Returns of ``episodes`` loops of ``steps`` on the disk, each from the start of seed ``k``."""
    out = []
    for k in range(episodes):
        env = EdgeFollowEnv(**ENV)
        obs, _ = env.reset(seed=100 + k)
        total = 0.0
        for _ in range(steps):
            obs, reward, terminated, _, _ = env.step(act(obs))
            total += reward
            if terminated:
                break
        out.append(total)
    return float(np.mean(out))


def test_a_short_ppo_run_beats_a_random_policy():
    torch.set_num_threads(1)
    vector = EdgeFollowVectorEnv(num_envs=4, max_episode_steps=40, autoreset_mode="same_step", **ENV)
    env = VecNormalize(VecMonitor(SB3VecEnv(vector, seed=0)), norm_obs=True, norm_reward=True)
    model = PPO("MlpPolicy", env, n_steps=128, batch_size=128, n_epochs=5, gamma=0.95, seed=0, verbose=0)
    model.learn(6144)
    env.training = False
    trained = episode_returns(lambda obs: model.predict(env.normalize_obs(obs[None]), deterministic=True)[0][0])
    rng = np.random.default_rng(0)
    random = episode_returns(lambda _obs: rng.uniform(-1, 1, 3).astype(np.float32))
    assert trained > random + 10.0, (trained, random)


def test_the_adapter_resets_in_the_step_that_ends_an_episode():
    vector = EdgeFollowVectorEnv(num_envs=2, max_episode_steps=3, autoreset_mode="same_step", **ENV)
    env = SB3VecEnv(vector, seed=5)
    first = env.reset()
    assert first.shape == (2, 331, 2)
    for step in range(3):
        obs, rewards, dones, infos = env.step(np.zeros((2, 3), np.float32))
    # The third step hits the step limit: both reset within it, their last observations kept.
    assert dones.all() and all(i["TimeLimit.truncated"] for i in infos), infos
    assert all(i["terminal_observation"].shape == (331, 2) for i in infos)
    assert not np.array_equal(obs[0], infos[0]["terminal_observation"]), "the new episode's first observation"
    with pytest.raises(ValueError, match="same_step"):
        SB3VecEnv(EdgeFollowVectorEnv(num_envs=1, **ENV))
