"""Throughput of the Python package (a release build: `pip install ./python`).

Prints and writes as JSON (``--json FILE``): images/s of taps (press + 128 px image), slides
(press + 2 mm slide in 0.25 mm steps + image), EdgeFollow-v0 steps/s with the oracle servo
(one environment, and the vector environment over all cores) with 128 px images, one thread
of Python driving each. Tactile Gym (its TacTip edge-follow environment) is not on PyPI, so
no ratio to it is measured here.

    python python/bench.py [--seconds 5] [--envs 8] [--json out.json]
"""

import argparse
import json
import os
import platform
import time

import numpy as np

import tacsim


def rate(fn, seconds):
    """Calls per second of fn over about `seconds` (after one warm-up call)."""
    fn()
    n, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        fn()
        n += 1
    return n / (time.perf_counter() - start)


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=5.0)
    p.add_argument("--envs", type=int, default=8)
    p.add_argument("--json")
    a = p.parse_args()
    rng = np.random.default_rng(0)
    # The edge-follow environment's sensor: the calibrated TacTip over a half-space.
    contact = tacsim.Contact(tacsim.Sensor.load("tactip-331-calibrated"), tacsim.Scene("square"))

    def tap():
        contact.press((45.0 + rng.uniform(-3, 3), rng.uniform(-5, 5), rng.uniform(0.5, 2.0), rng.uniform(-180, 180)))
        contact.image(128)

    def slide():
        x, y, d = 45.0 + rng.uniform(-3, 3), rng.uniform(-5, 5), rng.uniform(0.5, 2.0)
        contact.press((x, y, d, 0.0))
        contact.slide_to((x, y + 2.0, d, 0.0), step_mm=0.25)
        contact.image(128)

    figures = {"taps_per_s": rate(tap, a.seconds), "slides_per_s": rate(slide, a.seconds)}
    import gymnasium as gym

    env = gym.make("tacsim/EdgeFollow-v0", shape="clover").unwrapped
    env.reset(seed=0)

    def env_step():
        _, _, term, trunc, _ = env.step(env.servo_action())
        if term or trunc:
            env.reset()

    figures["edge_follow_steps_per_s"] = rate(env_step, a.seconds)
    vec = gym.make_vec("tacsim/EdgeFollow-v0", num_envs=a.envs, vectorization_mode="vector_entry_point", shape="clover")
    vec.reset(seed=0)
    inner = vec.unwrapped

    def vec_step():
        vec.step(np.stack([e.servo_action() for e in inner.envs]))

    figures["edge_follow_vector_env_steps_per_s"] = a.envs * rate(vec_step, a.seconds)
    figures.update(envs=a.envs, cores=os.cpu_count(), machine=platform.processor() or platform.machine())
    for k, v in figures.items():
        print(f"{k}: {v:.1f}" if isinstance(v, float) else f"{k}: {v}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(figures, f, indent=2)


if __name__ == "__main__":
    main()
