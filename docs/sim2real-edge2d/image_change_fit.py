"""How much each edge tap changes the image, real against simulated: the fit behind the
`edge-2d` recipe's depth range (issue 30).

For every image, the fraction of pin-field pixels (within 46 px of the centre at 128 px) that
differ from the undeformed image (real: the pixel-wise majority of the 30 most alike of the
shallowest half, as `tacsim calibrate` builds it: taps that touch nothing; simulated: the set's
own image_0.png). The simulated fraction is
tabulated over (lateral x, depth) and the real taps are looked up through a map
    sim x = sign * pose_2 + offset,   sim depth = gain * (pose_3 - zero)
whose parameters a grid search chooses (least squares) on the fitting 80% of the taps; the
held-out 20% (`tacsim_data::LabSample::is_held_out`: FNV-1a of the image name, one bucket of
five) only scores the result. Needs numpy, pillow, scipy.

    python3 docs/sim2real-edge2d/image_change_fit.py ../shared/data/real-tactip-edge2d SIMSET...
"""
import csv
import sys

import numpy as np
from PIL import Image
from scipy.interpolate import RegularGridInterpolator

YY, XX = np.mgrid[0:128, 0:128]
INNER = ((XX - 64.4) ** 2 + (YY - 64.5) ** 2) < 46 ** 2


def load(path):
    return np.array(Image.open(path).convert("L")) > 127


def is_held_out(name):
    h = 0xCBF29CE484222325
    for b in name.encode():
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h % 5 == 0


def alike_group(images, depth, k=30, pool=600):
    """The indices of the k most alike of the shallowest half (at most `pool`), as `tacsim
    calibrate` chooses a folder's reference (`Reference::consensus`): the image whose (k-1)-th
    nearest other is nearest, with those others. (Ties in depth here go by row order, there by
    image name.)"""
    order = np.argsort(depth, kind="stable")[: min(max(len(depth) // 2, k), pool)]
    packed = np.packbits(images[order].reshape(len(order), -1), axis=1)
    table = np.array([np.unpackbits(p ^ packed, axis=1).sum(1) for p in packed])
    np.fill_diagonal(table, np.iinfo(np.int64).max)
    near = np.sort(table, 1)[:, k - 2]
    best = int(np.argmin(near))
    return order[np.concatenate([[best], np.argsort(table[best], kind="stable")[: k - 1]])]


def consensus(images, depth, k=30, pool=600):
    """The pixel-wise majority of the [`alike_group`]."""
    return images[alike_group(images, depth, k, pool)].mean(0) > 0.5


def changes(images, reference):
    return np.array([(im ^ reference)[INNER].mean() for im in images])


def main(real_dir, sim_dirs):
    rows = list(csv.DictReader(open(f"{real_dir}/targets.csv")))
    imgs = np.array([load(f"{real_dir}/images/{r['sensor_image']}") for r in rows])
    depth = np.array([float(r["pose_3"]) for r in rows])
    lat = np.array([float(r["pose_2"]) for r in rows])
    ref = consensus(imgs, depth)
    real = changes(imgs, ref)
    held = np.array([is_held_out(r["sensor_image"]) for r in rows])
    print(f"real: {len(rows)} taps ({held.sum()} held out), image change {real.mean():.4f} +- {real.std():.4f}")
    for sim_dir in sim_dirs:
        srows = list(csv.DictReader(open(f"{sim_dir}/targets.csv")))
        simgs = np.array([load(f"{sim_dir}/images/{r['sensor_image']}") for r in srows])
        sd = np.array([float(r["pose_z"]) for r in srows])
        sx = np.array([float(r["pose_x"]) for r in srows])
        sim = changes(simgs, load(f"{sim_dir}/images/image_0.png"))
        xe = np.linspace(-6, 6, 13)
        de = np.linspace(sd.min(), sd.max(), 12)
        xc, dc = (xe[:-1] + xe[1:]) / 2, (de[:-1] + de[1:]) / 2
        table = np.full((len(xc), len(dc)), np.nan)
        for i in range(len(xc)):
            for j in range(len(dc)):
                m = (sx >= xe[i]) & (sx < xe[i + 1]) & (sd >= de[j]) & (sd < de[j + 1])
                if m.any():
                    table[i, j] = sim[m].mean()
        look = RegularGridInterpolator((xc, dc), table, bounds_error=False, fill_value=None)

        def predict(sign, offset, zero, gain):
            x = np.clip(sign * lat + offset, xc[0], xc[-1])
            d = np.clip(gain * (depth - zero), dc[0], dc[-1])
            return look(np.stack([x, d], 1))

        fit = ~held
        best = min(
            (np.mean((predict(s, o, z, g)[fit] - real[fit]) ** 2), s, o, z, g)
            for s in (-1, 1)
            for o in np.arange(-4, 4.01, 0.25)
            for z in np.arange(2.0, 3.55, 0.1)
            for g in np.arange(0.2, 1.55, 0.1)
        )
        _, s, o, z, g = best
        p = predict(s, o, z, g)
        rms = np.sqrt(np.mean((p[held] - real[held]) ** 2))
        print(
            f"{sim_dir}: held-out rms {rms:.4f}, correlation {np.corrcoef(p[held], real[held])[0, 1]:.3f}; "
            f"sim x = {s:+d} pose_2 {o:+.2f} mm; sim depth = {g:.1f} (pose_3 - {z:.1f}): "
            f"pose_3 3 -> {g * (3 - z):.2f} mm, 5 -> {g * (5 - z):.2f} mm"
        )


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
