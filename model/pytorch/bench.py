#!/usr/bin/env python3
"""The networks of `tacsim-model` in PyTorch, timed as `cargo xtask bench-model` times them.

The same layers (model/src/network.rs, model/src/posenet.rs), losses (model/src/objective.rs)
and measurement (model/src/bench.rs): batch 32 of uniform random images; Adam with PyTorch's
defaults but epsilon 1e-5 (burn's default) at 1e-4 (shear removal) and 1e-3 (pose network);
L1 1e-7 and L2 1e-6 on every weight of two or more dimensions; a self-supervised step (both
cycles, the forward and backward ones through a copy of D_S that takes no gradient, and the
reconstruction), a supervised step (L2, reconstruction and the patch loss over 100 random
crops of 20/256 of the side per image, the crops drawn on the CPU every step), a pose-network
step and unshear inference (E_S then D_T, in eval mode without gradients). Each rate is the
samples of as many steps as fit in 3 s after one warm-up step.

    python3 model/pytorch/bench.py --threads 1 --sizes 64 --json target/model-bench-pytorch-1.json

(`cargo xtask bench-model --pytorch PYTHON` runs it and prints the ratio to flex.)

PyTorch's wheel from PyPI runs on a CPU-only machine once its CUDA libraries are installed
beside it (`pip install torch numpy`).
"""

import argparse
import json
import os
import time

import numpy as np
import torch
from torch import nn

CODE = 64
# Stride-2 stages dropped relative to 256 px (network.rs, `Size::dropped`).
DROPPED = {256: 0, 128: 1, 64: 2}


def stages(full, size):
    """Encoder channels: the first stages dropped for smaller inputs."""
    return full[DROPPED[size] :]


def decoder(full, size):
    """Decoder channels: the stages before the output dropped for smaller outputs."""
    keep = len(full) - DROPPED[size]
    return full[: keep - 1] + [full[-1]]


def init(m):
    if isinstance(m, (nn.Conv2d, nn.ConvTranspose2d, nn.Linear)):
        nn.init.normal_(m.weight, 0.0, 0.02)
        nn.init.normal_(m.bias, 0.0, 0.02)


def conv_stack(cin, channels):
    layers = []
    for c in channels:
        layers += [nn.Conv2d(cin, c, 4, 2, 1), nn.BatchNorm2d(c), nn.ReLU()]
        cin = c
    return nn.Sequential(*layers)


def upsampler(cin, channels):
    layers = []
    for k, c in enumerate(channels):
        layers.append(nn.ConvTranspose2d(cin, c, 4, 2, 1))
        layers += [nn.BatchNorm2d(c), nn.ReLU()] if k + 1 < len(channels) else [nn.Sigmoid()]
        cin = c
    return nn.Sequential(*layers)


class ShearEncoder(nn.Module):
    def __init__(self, size):
        super().__init__()
        ch = stages([32, 64, 64, 128], size)
        self.trunk = conv_stack(1, ch)
        self.pose = nn.Sequential(nn.Conv2d(ch[-1], CODE, 4, 2, 1), nn.BatchNorm2d(CODE), nn.ReLU())
        self.shear = nn.Sequential(nn.Conv2d(ch[-1], CODE, 4, 2, 1), nn.BatchNorm2d(CODE), nn.ReLU())

    def forward(self, x):
        h = self.trunk(x)
        return self.pose(h), self.shear(h)


class Unshear(nn.Module):
    def __init__(self, size):
        super().__init__()
        self.es = ShearEncoder(size)
        self.dt = upsampler(CODE, decoder([64, 64, 32, 32, 1], size))
        self.ds = upsampler(2 * CODE, decoder([128, 64, 64, 32, 1], size))
        self.et = conv_stack(1, stages([32, 32, 64, 64, 64], size))
        self.apply(init)

    def unshear(self, x):
        return self.dt(self.es(x)[0])


class PoseNet(nn.Module):
    def __init__(self, size, hidden=128):
        super().__init__()
        self.trunk = conv_stack(1, stages([32, 32, 64, 64, 64], size))
        self.head = nn.Sequential(nn.Flatten(), nn.Linear(CODE * 64, hidden), nn.ReLU(), nn.Linear(hidden, 4))
        self.apply(init)

    def forward(self, x):
        return self.head(self.trunk(x))


def regularisation(model, l1=1e-7, l2=1e-6):
    ws = [p for p in model.parameters() if p.dim() >= 2]
    return sum(l1 * w.abs().sum() + l2 * w.square().sum() for w in ws)


def ds_frozen(model, codes):
    """D_S applied with its parameters detached: gradients flow to the codes only."""
    x = codes
    for layer in model.ds:
        if isinstance(layer, nn.ConvTranspose2d):
            x = nn.functional.conv_transpose2d(x, layer.weight.detach(), layer.bias.detach(), 2, 1)
        elif isinstance(layer, nn.BatchNorm2d):
            x = nn.functional.batch_norm(
                x, layer.running_mean, layer.running_var, layer.weight.detach(), layer.bias.detach(), True, 0.1, 1e-5
            )
        else:
            x = layer(x)
    return x


def self_supervised_loss(m, sheared, taps):
    mse = nn.functional.mse_loss
    pose, shear = m.es(sheared)
    unsheared = m.dt(pose)
    back = ds_frozen(m, torch.cat([m.et(unsheared), shear], 1))
    reconstruction = mse(m.ds(torch.cat([pose, shear], 1)), sheared)
    k = ds_frozen(m, torch.cat([m.et(taps), shear], 1))
    return mse(back, sheared) + mse(m.unshear(k), taps) + reconstruction + regularisation(m)


def patch_mask(batch, side, rng, count=100):
    crop = max(20 * side // 256, 4)
    mask = np.zeros((batch, 1, side, side), np.float32)
    span = side - crop + 1
    for b in range(batch):
        for x0, y0 in rng.integers(0, span, size=(count, 2)):
            mask[b, 0, y0 : y0 + crop, x0 : x0 + crop] += 1.0
    return torch.from_numpy(mask), batch * count * crop * crop


def supervised_loss(m, sheared, taps, rng):
    mse = nn.functional.mse_loss
    pose, shear = m.es(sheared)
    unsheared = m.dt(pose)
    reconstruction = mse(m.ds(torch.cat([pose, shear], 1)), sheared)
    mask, norm = patch_mask(sheared.shape[0], sheared.shape[-1], rng)
    patch = ((unsheared - taps).abs() * mask).sum() / norm
    return reconstruction + mse(unsheared, taps) + regularisation(m) + 0.1 * patch


def rate(samples, step):
    step()
    t = time.perf_counter()
    n = 0
    while n == 0 or time.perf_counter() - t < 3.0:
        step()
        n += 1
    return n * samples / (time.perf_counter() - t)


def measure(size, batch=32):
    img = lambda: torch.rand(batch, 1, size, size)  # noqa: E731
    m = Unshear(size)
    opt = torch.optim.Adam(m.parameters(), lr=1e-4, eps=1e-5)

    def train(loss):
        opt.zero_grad(set_to_none=True)
        loss().backward()
        opt.step()

    ss = rate(batch, lambda: train(lambda: self_supervised_loss(m, img(), img())))
    sup = rate(batch, lambda: train(lambda: supervised_loss(m, img(), img(), np.random.default_rng(0))))
    p = PoseNet(size)
    popt = torch.optim.Adam(p.parameters(), lr=1e-3, eps=1e-5)
    target = torch.zeros(batch, 4)

    def pose_step():
        popt.zero_grad(set_to_none=True)
        (p(img()) - target).square().mean().backward()
        popt.step()

    ps = rate(batch, pose_step)
    m.eval()
    x = img()
    with torch.no_grad():
        inf = rate(batch, lambda: m.unshear(x).numpy())
    return {
        "backend": f"pytorch {torch.__version__} cpu, {torch.get_num_threads()} thread(s)",
        "size": size,
        "batch": batch,
        "self_supervised_samples_per_s": ss,
        "supervised_samples_per_s": sup,
        "posenet_samples_per_s": ps,
        "inference_images_per_s": inf,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=os.cpu_count(), help="intra-op threads (default: all cores)")
    ap.add_argument("--sizes", default="256,128,64", help="image sides (px), comma-separated")
    ap.add_argument("--json", help="write the rows here (atomically)")
    a = ap.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(0)
    rows = []
    for size in (int(s) for s in a.sizes.split(",")):
        row = measure(size)
        print(json.dumps(row), flush=True)
        rows.append(row)
    if a.json:
        tmp = a.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump(rows, f, indent=2)
            f.write("\n")
        os.replace(tmp, a.json)


if __name__ == "__main__":
    main()
