"""Train an edge-following policy on tacsim with Stable-Baselines3's PPO, then follow every
built-in stimulus closed-loop with it and with the oracle servo.

The policy sees the pins' displacement in the image (``obs_type="pins"``, 331 x 2 px at
128 px) and gives the servo's lateral move, turn and step (``tacsim/EdgeFollow-v0``); it is
trained on 8 environments in one vector env (``EdgeFollowVectorEnv``, every slide in one call
on all cores), each episode on a stimulus drawn from all seven, from a random point of its
edge. Then, for each stimulus, one closed loop from a fixed start with the trained policy
(its mean action) and with the oracle servo (``servo_action``, the true edge pose), scored
with ``scenarios/explore``'s criteria for perception read off the pins: completion >= 0.95,
mean deviation <= 1.0 mm, largest deviation <= 3.0 mm. The scenarios' IoU reconstructs the
shape from a perception's contact estimates, which a policy does not make; in its place the
region the traced path encloses is compared with the outline (``traced_iou``, reported, not
in the pass).

    pip install './python[ray]' stable-baselines3 torch matplotlib
    python examples/python/train_policy.py --steps 150000 --out policy

writes ``policy/model.zip`` (and ``vecnormalize.pkl``), ``policy/results.json``,
``policy/curve.svg`` (mean episode return against steps) and prints the table. Rerun with
``--evaluate`` to score a saved policy without training. ``--ray N`` steps the environments
on N Ray actors instead (``RayEdgeFollowVectorEnv``).
"""

import argparse
import json
import math
import pathlib
import sys
import time

import numpy as np

import tacsim
from tacsim.envs import EdgeFollowEnv, EdgeFollowVectorEnv

try:
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from tacsim.envs.sb3 import SB3VecEnv
except ImportError:
    print("Stable-Baselines3 and PyTorch are not installed (pip install stable-baselines3 torch): skipped")
    sys.exit(0)

# scenarios/explore's criteria for perception read off the pins (`*-geometric.toml`).
COMPLETION, MEAN_DEVIATION_MM, MAX_DEVIATION_MM = 0.95, 1.0, 3.0
ENV = dict(obs_type="pins", image_size=128, depth_mm=1.5, max_step_mm=2.0)


def make_env(envs, seed, ray_actors):
    kwargs = dict(ENV, shape=tacsim.shapes(), max_episode_steps=100, autoreset_mode="same_step")
    if ray_actors:
        from tacsim.envs import RayEdgeFollowVectorEnv

        vector = RayEdgeFollowVectorEnv(num_envs=envs, actors=ray_actors, **kwargs)
    else:
        vector = EdgeFollowVectorEnv(num_envs=envs, **kwargs)
    return VecNormalize(VecMonitor(SB3VecEnv(vector, seed=seed)), norm_obs=True, norm_reward=True)


class Curve(BaseCallback):
    """Mean return of the last finished episodes, every ``every`` steps."""

    def __init__(self, every):
        super().__init__()
        self.every, self.last, self.points, self.start = every, 0, [], time.monotonic()

    def _on_step(self):
        if self.num_timesteps - self.last >= self.every and self.model.ep_info_buffer:
            self.last = self.num_timesteps
            ret = float(np.mean([e["r"] for e in self.model.ep_info_buffer]))
            self.points.append((self.num_timesteps, ret))
            print(f"{self.num_timesteps:>8} steps  {time.monotonic() - self.start:6.0f} s  mean return {ret:7.2f}")
        return True


def inside(polygon, points):
    """Whether each of ``points`` (n, 2) lies inside the closed ``polygon`` (m, 2): even-odd rule."""
    x, y = points[:, 0][:, None], points[:, 1][:, None]
    a, b = polygon, np.roll(polygon, -1, axis=0)
    crosses = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (crosses & (x < at)).sum(axis=1) % 2 == 1


def traced_iou(outline, path, cell_mm=0.25):
    """IoU of the region the sensor's traced path encloses with the stimulus's outline, on a
    ``cell_mm`` grid: how well the path alone would reconstruct the shape."""
    both = np.vstack([outline, path])
    lo, hi = both.min(axis=0) - 1.0, both.max(axis=0) + 1.0
    xs, ys = np.arange(lo[0], hi[0], cell_mm), np.arange(lo[1], hi[1], cell_mm)
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    a, b = inside(outline, grid), inside(path, grid)
    return float((a & b).sum() / max((a | b).sum(), 1))


def closed_loop(shape, act):
    """One loop round ``shape`` from a fixed start: completion, deviations (mm) and the traced
    path's IoU with the outline."""
    env = EdgeFollowEnv(shape=shape, **ENV)
    obs, info = env.reset(seed=0)
    perimeter = env.contour.perimeter
    deviations, path = [info["deviation_mm"]], [env.pose[:2]]
    for _ in range(math.ceil(1.5 * perimeter / ENV["max_step_mm"])):
        obs, _, terminated, _, info = env.step(act(env, obs))
        deviations.append(info["deviation_mm"])
        path.append(env.pose[:2])
        if terminated:
            break
    completion = min(1.0, info["progress_mm"] / perimeter)
    mean_dev, max_dev = float(np.mean(deviations)), float(np.max(deviations))
    passed = completion >= COMPLETION and mean_dev <= MEAN_DEVIATION_MM and max_dev <= MAX_DEVIATION_MM
    iou = traced_iou(env.contour.points, np.asarray(path, dtype=np.float64))
    return {
        "completion": completion,
        "mean_deviation_mm": mean_dev,
        "max_deviation_mm": max_dev,
        "traced_iou": iou,
        "pass": passed,
    }


def write_curve(points, path):
    try:
        import matplotlib

        matplotlib.use("svg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no curve.svg")
        return
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot([p[0] for p in points], [p[1] for p in points])
    ax.set_xlabel("environment steps")
    ax.set_ylabel("mean episode return")
    ax.set_title("PPO on tacsim/EdgeFollow-v0 (pins, all seven stimuli)")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, metadata={"Date": None})


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=150_000, help="environment steps to train (default 150,000)")
    ap.add_argument("--envs", type=int, default=8, help="environments stepped together (default 8)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ray", type=int, default=0, metavar="N", help="step the environments on N Ray actors")
    ap.add_argument("--out", default="policy", help="folder for the model, results.json and curve.svg")
    ap.add_argument("--evaluate", action="store_true", help="score the saved policy in --out, no training")
    args = ap.parse_args()
    if not 1 <= args.steps <= 100_000_000 or not 1 <= args.envs <= 1024:
        ap.error("--steps must lie in [1, 1e8] and --envs in [1, 1024]")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(1)
    env = make_env(args.envs, args.seed, args.ray)
    curve = Curve(every=4096)
    if args.evaluate:
        env = VecNormalize.load(str(out / "vecnormalize.pkl"), env.venv)
        model = PPO.load(str(out / "model.zip"), env=env)
        wall = None
    else:
        model = PPO(
            "MlpPolicy",
            env,
            n_steps=128,
            batch_size=256,
            n_epochs=5,
            learning_rate=3e-4,
            gamma=0.95,
            seed=args.seed,
            policy_kwargs=dict(net_arch=[64, 64]),
            verbose=0,
        )
        start = time.monotonic()
        model.learn(args.steps, callback=curve)
        wall = time.monotonic() - start
        model.save(str(out / "model.zip"))
        env.save(str(out / "vecnormalize.pkl"))
        write_curve(curve.points, out / "curve.svg")
    env.training = False

    def policy(_env, obs):
        action, _ = model.predict(env.normalize_obs(obs[None]), deterministic=True)
        return action[0]

    results = {"steps": args.steps, "envs": args.envs, "seed": args.seed, "train_wall_s": wall, "curve": curve.points}
    if args.evaluate and (out / "results.json").exists():
        # The training's own record stays; the scores are made again.
        kept = json.loads((out / "results.json").read_text())
        results.update({k: kept[k] for k in ("steps", "envs", "seed", "train_wall_s", "curve") if k in kept})
    print(f"{'stimulus':<10} {'policy: completion / mean / max dev (mm) / IoU':<46} oracle servo")
    results["stimuli"] = {}
    for shape in tacsim.shapes():
        learned = closed_loop(shape, policy)
        oracle = closed_loop(shape, lambda e, _obs: e.servo_action())
        results["stimuli"][shape] = {"policy": learned, "oracle": oracle}

        def row(r):
            dev = f"{r['mean_deviation_mm']:.2f} / {r['max_deviation_mm']:.2f}"
            return f"{r['completion']:.2f} / {dev} / {r['traced_iou']:.3f} {'pass' if r['pass'] else 'fail'}"

        print(f"{shape:<10} {row(learned):<46} {row(oracle)}")
    passed = sum(r["policy"]["pass"] for r in results["stimuli"].values())
    results["policy_passes"] = passed
    print(f"the policy follows {passed} of {len(results['stimuli'])} stimuli")
    (out / "results.json").write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
