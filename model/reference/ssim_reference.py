"""Reference SSIM and MS-SSIM values for tacsim-model's metrics tests.

SSIM: scikit-image's structural_similarity with the standard settings (Gaussian window,
sigma 1.5, K1 0.01, K2 0.03, population covariances, data range 1). Its mean over the image
cropped by the window radius equals a valid (unpadded) 11-tap Gaussian filtering.

MS-SSIM: the algorithm of pytorch-msssim (Wang, Simoncelli & Bovik 2003) written here with
numpy/scipy, since no torch is installed: contrast-structure terms at each scale, SSIM at the
last, weights (0.0448, 0.2856, 0.3001, 0.2363, 0.1333), 2x2 average pooling between scales
(zero-padding odd sizes, as avg_pool2d with padding does), negative terms clamped to 0. For
inputs too small for 5 scales (the last scale must be at least 11 px) it uses the first n
weights, renormalised.

Run: python3 model/reference/ssim_reference.py > model/reference/ssim_reference.json
"""
import json

import numpy as np
from scipy.ndimage import correlate1d
from skimage.metrics import structural_similarity

WEIGHTS = [0.0448, 0.2856, 0.3001, 0.2363, 0.1333]
K1, K2, SIGMA, WIN = 0.01, 0.03, 1.5, 11


def image(kind, n):
    y, x = np.mgrid[0:n, 0:n].astype(np.float64)
    a = 0.5 + 0.5 * np.sin(x / 7.0) * np.cos(y / 11.0)
    if kind == "a":
        return a
    return np.clip(a + 0.1 * np.sin((x + 2.0 * y) / 5.0), 0.0, 1.0)


def gauss():
    r = np.arange(WIN) - WIN // 2
    g = np.exp(-(r ** 2) / (2 * SIGMA ** 2))
    return g / g.sum()


def filt(img):
    g = gauss()
    out = correlate1d(img, g, axis=0, mode="constant")
    out = correlate1d(out, g, axis=1, mode="constant")
    c = WIN // 2
    return out[c:-c, c:-c]


def ssim_cs(a, b):
    c1, c2 = K1 ** 2, K2 ** 2
    mu_a, mu_b = filt(a), filt(b)
    saa = filt(a * a) - mu_a ** 2
    sbb = filt(b * b) - mu_b ** 2
    sab = filt(a * b) - mu_a * mu_b
    cs = (2 * sab + c2) / (saa + sbb + c2)
    ssim = (2 * mu_a * mu_b + c1) / (mu_a ** 2 + mu_b ** 2 + c1) * cs
    return ssim.mean(), cs.mean()


def pool(img):
    h, w = img.shape
    img = np.pad(img, ((0, h % 2), (0, w % 2)))
    return img.reshape(img.shape[0] // 2, 2, img.shape[1] // 2, 2).mean(axis=(1, 3))


def ms_ssim(a, b):
    n = a.shape[0]
    levels = 1
    while levels < 5 and n // 2 ** levels >= WIN:
        levels += 1
    w = np.array(WEIGHTS[:levels])
    w = w / w.sum()
    vals = []
    for level in range(levels):
        s, cs = ssim_cs(a, b)
        vals.append(max(cs, 0.0) if level < levels - 1 else max(s, 0.0))
        a, b = pool(a), pool(b)
    return float(np.prod(np.array(vals) ** w)), levels


out = {}
for n in (256, 128, 64):
    a, b = image("a", n), image("b", n)
    sk = structural_similarity(a, b, gaussian_weights=True, sigma=SIGMA, use_sample_covariance=False, data_range=1.0)
    own, _ = ssim_cs(a, b)
    assert abs(sk - own) < 1e-12, (sk, own)
    ms, levels = ms_ssim(a, b)
    out[str(n)] = {"ssim_skimage": float(sk), "ms_ssim": ms, "ms_ssim_levels": levels}
print(json.dumps(out, indent=2))
