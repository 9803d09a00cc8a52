"""The viewer's one extra kernel: lay a picture field over part of the window image.

(No ``from __future__ import annotations`` here: Taichi reads kernel annotations as objects.)
"""

import taichi as ti


@ti.kernel
def blit(dst: ti.template(), src: ti.template(), x0: ti.i32, y0: ti.i32, y_min: ti.i32, a: ti.f32):
    """``dst[x0 + p, y0 + q] = a src[p, q] + (1 - a) dst[...]`` (a = 1 replaces, below 1
    blends), clipped to ``dst`` and to its rows from ``y_min`` up."""
    for p, q in src:
        x, y = x0 + p, y0 + q
        if 0 <= x < dst.shape[0] and y_min <= y < dst.shape[1]:
            dst[x, y] = ti.cast(a * src[p, q] + (1.0 - a) * dst[x, y], ti.f32)
