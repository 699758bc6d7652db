#!/usr/bin/env python3
"""score.py ours.exr reference.exr: the mean luminance ratio and the mean
8x8-block relative error over lit blocks, as linkgi's reference::image::score."""
import sys, numpy as np, OpenEXR
def load(p):
    f = OpenEXR.File(p)
    ch = f.channels()
    if 'RGB' in ch:
        a = ch['RGB'].pixels
    else:
        a = np.stack([ch[c].pixels for c in 'RGB'], -1)
    return np.asarray(a, dtype=np.float64)
a, b = load(sys.argv[1]), load(sys.argv[2])
# ours at an integer multiple of the reference's size: box-filtered down to it
while a.shape[0] > b.shape[0] and a.shape[0] % 2 == 0:
    a = 0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])
assert a.shape == b.shape, (a.shape, b.shape)
w = np.array([0.2126, 0.7152, 0.0722])
la, lb = a @ w, b @ w
def blocks(l):
    h, wd = l.shape; B = 8
    bh, bw = -(-h // B), -(-wd // B)
    s = np.zeros((bh, bw)); c = np.zeros((bh, bw))
    for y in range(h):
        np.add.at(s[y // B], np.arange(wd) // B, l[y]); np.add.at(c[y // B], np.arange(wd) // B, 1)
    return s / np.maximum(c, 1)
ba, bb = blocks(la), blocks(lb)
ref_mean = lb.mean()
lit = bb > 0.01 * ref_mean
err = np.abs(ba[lit] - bb[lit]) / bb[lit]
print(f"mean_ratio {la.mean() / ref_mean:.4f} block_error {err.mean():.4f} blocks {lit.sum()}")
