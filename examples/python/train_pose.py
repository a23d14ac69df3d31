"""Train a tiny pose regressor on simulated edge taps with PyTorch (skipped without it).

Taps on the square's edge at a random lateral offset (mm) and yaw (deg), 64 px crops of the
128 px images; a small CNN learns (offset, cos yaw, sin yaw) and reports its held-out error.

    pip install ./python torch && python examples/python/train_pose.py
"""

import math
import sys

import numpy as np

import tacsim

try:
    import torch
    from torch import nn
except ImportError:
    print("PyTorch is not installed (pip install torch): skipped")
    sys.exit(0)

rng = np.random.default_rng(0)
contact = tacsim.Contact(tacsim.Sensor.load("tactip-331-edge2d"), tacsim.Scene("square"), max_depth_mm=2.0)
images, labels = [], []
for _ in range(1500):
    x, yaw = rng.uniform(-4, 4), rng.uniform(-180, 180)
    contact.press((45.0 + x, 0.0, 1.5, yaw))
    images.append(contact.image(128)[::2, ::2] / 255.0)
    labels.append([x, math.cos(math.radians(yaw)), math.sin(math.radians(yaw))])
x = torch.tensor(np.array(images), dtype=torch.float32)[:, None]
y = torch.tensor(labels, dtype=torch.float32)
net = nn.Sequential(
    nn.Conv2d(1, 16, 5, 2, 2), nn.ReLU(), nn.Conv2d(16, 32, 5, 2, 2), nn.ReLU(),
    nn.Conv2d(32, 32, 3, 2, 1), nn.ReLU(), nn.Flatten(), nn.Linear(32 * 8 * 8, 64), nn.ReLU(), nn.Linear(64, 3),
)
opt = torch.optim.Adam(net.parameters(), 1e-3)
train, test = slice(0, 1200), slice(1200, None)
for epoch in range(15):
    for i in torch.randperm(1200).split(32):
        loss = nn.functional.mse_loss(net(x[train][i]), y[train][i])
        opt.zero_grad()
        loss.backward()
        opt.step()
with torch.no_grad():
    p = net(x[test])
lateral = (p[:, 0] - y[test][:, 0]).abs().mean().item()
yaw = torch.atan2(p[:, 2], p[:, 1]) - torch.atan2(y[test][:, 2], y[test][:, 1])
yaw = torch.rad2deg(torch.atan2(torch.sin(yaw), torch.cos(yaw))).abs().mean().item()
print(f"held-out taps: lateral {lateral:.2f} mm, yaw {yaw:.1f} deg")
