"""The Gymnasium environments: the env checker, the closed loop, the vector env."""

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="pip install gymnasium to test the environments")
from gymnasium.utils.env_checker import check_env  # noqa: E402

import tacsim  # noqa: E402,F401  (registers the environments)
from tacsim.envs import EdgeFollowEnv, EdgeFollowVectorEnv, SurfacePoseEnv  # noqa: E402


@pytest.mark.parametrize("env_id", ["tacsim/EdgeFollow-v0", "tacsim/SurfacePose-v0"])
def test_the_env_checker_passes(env_id):
    check_env(gym.make(env_id).unwrapped, skip_render_check=False)


@pytest.mark.parametrize("obs_type", ["pins", "both"])
def test_pin_observations_are_in_their_space(obs_type):
    env = EdgeFollowEnv(shape="disk", obs_type=obs_type)
    obs, _ = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    obs, *_ = env.step(env.servo_action())
    assert env.observation_space.contains(obs)
    pins = obs["pins"] if obs_type == "both" else obs
    assert np.abs(pins).max() > 0.1, "pressed pins move in the image"


@pytest.mark.parametrize("shape", ["disk", "square"])
def test_an_oracle_servo_closes_the_loop_on_the_edge(shape):
    env = gym.make("tacsim/EdgeFollow-v0", shape=shape)
    env.reset(seed=0)
    deviations = []
    for _ in range(500):
        _, _, terminated, truncated, info = env.step(env.unwrapped.servo_action())
        deviations.append(info["deviation_mm"])
        if terminated or truncated:
            break
    assert info["closed"] and not info["lost"], info
    perimeter = env.unwrapped.contour.perimeter
    assert abs(info["progress_mm"] - perimeter) < 2.0, (info, perimeter)
    assert np.mean(deviations) < 0.3, np.mean(deviations)


def test_leaving_the_edge_ends_the_episode():
    env = EdgeFollowEnv(shape="disk")
    env.reset(seed=0)
    for _ in range(20):
        _, reward, terminated, _, info = env.step(np.array([1.0, 0.0, -1.0], np.float32))  # straight off the material
        if terminated:
            break
    assert terminated and info["lost"] and reward < 0


def test_reset_options_pick_the_shape_and_start():
    env = EdgeFollowEnv(shape="disk")
    _, info = env.reset(seed=0, options={"shape": "clover", "start_mm": (0.0, -100.0)})
    assert env.scene.names == ["clover"]
    assert info["deviation_mm"] < 1e-6


def test_the_vector_env_equals_single_envs_stepped_alike():
    n, steps = 3, 12
    vec = gym.make_vec("tacsim/EdgeFollow-v0", num_envs=n, vectorization_mode="vector_entry_point", shape="clover")
    assert isinstance(vec.unwrapped, EdgeFollowVectorEnv)
    singles = [EdgeFollowEnv(shape="clover") for _ in range(n)]
    obs, _ = vec.reset(seed=7)
    for i, env in enumerate(singles):
        o, _ = env.reset(seed=7 + i)
        np.testing.assert_array_equal(obs[i], o)
    rng = np.random.default_rng(0)
    for _ in range(steps):
        # Small corrections about the servo's: the edges stay under the sensors.
        actions = np.stack([env.servo_action() for env in singles]) + rng.uniform(-0.2, 0.2, size=(n, 3))
        actions = actions.clip(-1, 1).astype(np.float32)
        obs, rewards, terminated, truncated, _ = vec.step(actions)
        for i, env in enumerate(singles):
            o, r, term, _, _ = env.step(actions[i])
            np.testing.assert_array_equal(obs[i], o)
            assert rewards[i] == r and terminated[i] == term and not term
    assert vec.observation_space.contains(obs)


def test_surface_pose_rewards_the_truth_and_is_seeded():
    env = gym.make("tacsim/SurfacePose-v0")
    obs_a, info_a = env.reset(seed=5)
    obs_b, info_b = env.reset(seed=5)
    np.testing.assert_array_equal(obs_a, obs_b)
    assert info_a["pose"] == info_b["pose"]
    _, reward, terminated, _, info = env.step(env.unwrapped.action_of(info_a["pose"]))
    assert terminated and abs(reward) < 1e-5 and max(info["error"]) < 1e-5
    env.reset(seed=6)
    _, worse, *_ = env.step(np.array([-1.0, 1.0, 1.0], np.float32))
    assert worse < -0.1


def test_the_most_tilted_deepest_press_stays_inside_the_contact_grid():
    env = SurfacePoseEnv()
    env.contact.press((0.0, 0.0, env.depth[1], 0.0, env.tilt, -env.tilt))
    p, _ = env.contact.pressure()
    assert p.max() > 0 and p[0].max() == p[-1].max() == p[:, 0].max() == p[:, -1].max() == 0.0


@pytest.mark.parametrize(
    "make, needle",
    [
        (lambda: EdgeFollowEnv(obs_type="pixels"), "obs_type"),
        (lambda: EdgeFollowEnv(depth_mm=9.0), "depth_mm"),
        (lambda: EdgeFollowEnv(shape="cube"), "cube"),
        (lambda: SurfacePoseEnv(tilt_deg=60.0), "tilt_deg"),
        (lambda: EdgeFollowVectorEnv(num_envs=0), "num_envs"),
    ],
)
def test_bad_environment_arguments_raise_value_error(make, needle):
    with pytest.raises(ValueError) as e:
        make()
    assert needle in str(e.value)
