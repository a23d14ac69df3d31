"""Ray (tacsim.ray) on a local 2-CPU cluster: the merged shards have the bytes of one machine's
run, a killed task is retried and resumes its shard, bad arguments are refused before any task
runs; the Ray vector environment equals the local one.

Needs the ``ray`` extra (``pip install './python[ray]'``): skipped without it, saying so, and
a failure under CI=true, where .ci/run installs it.
"""

import os
import pathlib

import numpy as np
import pytest

import tacsim

if os.environ.get("CI") == "true":
    import ray  # the extra is installed in CI: its absence fails the suite there
else:
    ray = pytest.importorskip("ray", reason="pip install './python[ray]' to test tacsim.ray")

import tacsim.ray as tray  # noqa: E402


def files(folder: pathlib.Path) -> dict:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def cluster():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, object_store_memory=80 * 1024 * 1024)
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def one_machine(tmp_path_factory):
    out = tmp_path_factory.mktemp("one") / "quick"
    tacsim.generate("quick", str(out), threads=2)
    return files(out)


def test_four_shards_on_ray_have_the_bytes_of_one_machine(tmp_path, cluster, one_machine):
    out = tmp_path / "quick"
    seen = []
    data = tray.generate("quick", str(out), shards=4, cpus_per_shard=1, progress=lambda d, t: seen.append((d, t)))
    assert len(data) == 300
    assert files(out) == one_machine
    assert not (tmp_path / "quick.shards").exists(), "the shards are removed after the merge"
    assert seen and seen[-1] == (300, 300) and all(d <= t for d, t in seen)
    # The same call again: every shard resumes with nothing to do, the merge finishes.
    runs = tray.generate_shards("quick", str(tmp_path / "again"), 4, cpus_per_shard=1)
    again = tray.generate_shards("quick", str(tmp_path / "again"), 4, cpus_per_shard=1)
    assert [r.images for r in runs] == [75, 75, 75, 75]
    # By default one shard per alive node: one here.
    assert [r.shards for r in tray.generate_shards("quick", str(tmp_path / "nodes"), cpus_per_shard=1)] == [1]
    assert all(r.written == 0 and r.skipped == r.images for r in again), again


def test_a_killed_task_is_retried_and_resumes_its_shard(tmp_path, cluster, one_machine):
    root = tmp_path / "shards"
    runs = tray.generate_shards("quick", str(root), 2, cpus_per_shard=1, _kill_after=(0, 20))
    assert (root / "shard-0-of-2.killed").exists(), "the first attempt's worker was killed"
    first, second = runs
    assert first.skipped >= 20 and first.written + first.skipped == first.images == 150, first
    assert second.skipped == 0 and second.written == 150, second
    merged = tmp_path / "merged"
    assert tacsim.merge(str(merged), [r.folder for r in runs]) == 300
    assert files(merged) == one_machine


def test_bad_arguments_are_refused_before_any_task_runs(tmp_path):
    with pytest.raises(ValueError, match=r"shards must be a whole number in \[1, 100000\], got 0"):
        tray.generate_shards("quick", str(tmp_path / "s"), 0)
    with pytest.raises(ValueError, match="cpus_per_shard"):
        tray.generate_shards("quick", str(tmp_path / "s"), 2, cpus_per_shard=0)
    with pytest.raises(ValueError, match="no-such-recipe"):
        tray.generate_shards("no-such-recipe", str(tmp_path / "s"), 2, cpus_per_shard=1)
    with pytest.raises(ValueError, match="no-such-recipe"):
        tray.generate("no-such-recipe", str(tmp_path / "s"))
    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(ValueError, match="is not a folder"):
        tray.generate("quick", str(tmp_path / "file"), shards=2, cpus_per_shard=1)
    with pytest.raises(ValueError, match="inside out"):
        tray.generate("quick", str(tmp_path / "o"), shards=2, shard_root=str(tmp_path / "o" / "s"))
    assert not (tmp_path / "s").exists() and not (tmp_path / "o").exists(), "nothing written"


def test_the_ray_vector_env_equals_the_local_one(cluster):
    from tacsim.envs import EdgeFollowVectorEnv, RayEdgeFollowVectorEnv

    n, steps = 5, 8
    kwargs = dict(shape="clover", obs_type="pins", max_episode_steps=6)
    remote = RayEdgeFollowVectorEnv(num_envs=n, actors=2, **kwargs)
    local = EdgeFollowVectorEnv(num_envs=n, **kwargs)
    assert remote.observation_space == local.observation_space and remote.action_space == local.action_space
    a, info_a = remote.reset(seed=11)
    b, info_b = local.reset(seed=11)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(info_a["progress_mm"], info_b["progress_mm"])
    rng = np.random.default_rng(1)
    ended = 0
    for _ in range(steps):
        # Past max_episode_steps = 6: every environment is truncated and autoreset once.
        actions = rng.uniform(-0.3, 0.3, size=(n, 3)).astype(np.float32)
        ra, rb = remote.step(actions), local.step(actions)
        for x, y in zip(ra[:4], rb[:4]):
            np.testing.assert_array_equal(x, y)
        for k in ("progress_mm", "deviation_mm", "_progress_mm"):
            np.testing.assert_array_equal(ra[4][k], rb[4][k])
        ended += int(ra[2].sum() + ra[3].sum())
    assert ended >= n, "each environment ended (and was reset) at least once"
    remote.close()
    # The same-step autoreset (Stable-Baselines3's): the ended episodes' last observations too.
    kwargs["autoreset_mode"] = "same_step"
    remote, local = RayEdgeFollowVectorEnv(num_envs=3, actors=2, **kwargs), EdgeFollowVectorEnv(num_envs=3, **kwargs)
    remote.reset(seed=2), local.reset(seed=2)
    for _ in range(6):
        ra, rb = remote.step(np.zeros((3, 3), np.float32)), local.step(np.zeros((3, 3), np.float32))
        for x, y in zip(ra[:4], rb[:4]):
            np.testing.assert_array_equal(x, y)
    assert ra[3].all() and list(ra[4]["_final_obs"]) == [True] * 3
    for x, y in zip(ra[4]["final_obs"], rb[4]["final_obs"]):
        np.testing.assert_array_equal(x, y)
    remote.close()
    with pytest.raises(ValueError, match=r"actors must be a whole number in \[1, num_envs = 2\], got 3"):
        RayEdgeFollowVectorEnv(num_envs=2, actors=3)
