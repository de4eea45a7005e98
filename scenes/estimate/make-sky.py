#!/usr/bin/env python3
"""Writes sky.pfm, the environment map of motion.pbrt: a 64x32
latitude-longitude sky (pbrt-v3's equirectangular layout, +z up), bluer
towards the zenith, a dim ground, and a small sun 3 pixels wide that
carries most of the light. Run from this folder: python3 make-sky.py"""
import math
import struct

W, H = 64, 32
SUN_U, SUN_V = 0.30, 0.22  # the sun's place in the map (u across, v down)


def texel(x, y):
    v = (y + 0.5) / H  # 0 at the zenith, 1 at the nadir
    u = (x + 0.5) / W
    if v > 0.5:  # below the horizon
        return (0.05, 0.045, 0.04)
    up = 1.0 - 2.0 * v  # 1 at the zenith, 0 at the horizon
    sky = (0.35 + 0.25 * (1 - up), 0.5 + 0.15 * (1 - up), 0.9)
    du = min(abs(u - SUN_U), 1 - abs(u - SUN_U)) * W
    dv = abs(v - SUN_V) * H
    if du < 1.5 and dv < 1.5:
        return (400.0, 380.0, 330.0)
    return sky


rows = []
# PFM stores rows bottom to top; pbrt-v3 flips them back on reading.
for y in reversed(range(H)):
    rows.append(b"".join(struct.pack("<3f", *texel(x, y)) for x in range(W)))
with open("sky.pfm", "wb") as f:
    f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
    f.write(b"".join(rows))
