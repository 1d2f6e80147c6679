"""The camera stage: a wavefront's first rays, through Owen-scrambled Sobol points of each path's pixel."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from core.jit import kernel
from renderer.qmc import key, sobol2
from renderer.stages.primitives import PAIR_PIXEL


@njit(inline="always", nogil=True, cache=True)
def camera_ray(camera, col, row):
    """Unit direction of ``camera``'s (:class:`~renderer.stages.records.PinholeCamera`) ray through image
    point ``(col, row)`` (pixels, row 0 at the top)."""
    width, height, tan_half, aspect = camera.width, camera.height, camera.tan_half, camera.aspect
    forward, right, up = camera.forward, camera.right, camera.up
    x = (2.0 * col / width - 1.0) * tan_half * aspect
    y = (1.0 - 2.0 * row / height) * tan_half
    dx = forward[0] + x * right[0] + y * up[0]
    dy = forward[1] + x * right[1] + y * up[1]
    dz = forward[2] + x * right[2] + y * up[2]
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    return dx / length, dy / length, dz / length


@njit(nogil=True, cache=True)
def camera_rays(pixels, jitter, camera):
    """Rays of ``camera`` through jittered points of ``pixels`` (row-major, row 0 at the top): ``o, d (n, 3)``."""
    width, origin = camera.width, camera.origin
    n = pixels.shape[0]
    o = np.empty((n, 3))
    d = np.empty((n, 3))
    for i in range(n):
        row = pixels[i] // width
        col = pixels[i] - row * width
        d[i, 0], d[i, 1], d[i, 2] = camera_ray(camera, col + jitter[i, 0], row + jitter[i, 1])
        o[i, 0], o[i, 1], o[i, 2] = origin[0], origin[1], origin[2]
    return o, d


@kernel
def camera_stage(a, b, j0, block, step, keys, camera, rays):
    """Camera rays of rows ``[a, b)`` into ``rays`` (:class:`~renderer.stages.records.Rays`): row ``r`` is path
    ``j = j0 + (r // block) * step + r % block`` (runs of ``block`` paths, ``step`` apart: a wavefront
    interleaved with others; ``block = step`` for consecutive paths), sample ``keys.first_sample + j //
    keys.n_pix`` of pixel ``j % keys.n_pix``, through the pixel's Owen-scrambled Sobol point of that sample
    number. Within a run the pixel, its row and column and the sample number are advanced by one path at a
    time (the integer divisions once a run instead of four a ray)."""
    n_pix, first_sample, seed_key = keys.n_pix, keys.first_sample, keys.seed_key
    width, origin = camera.width, camera.origin
    o, d, o32, d32 = rays.o, rays.d, rays.o32, rays.d32
    beta, path, prev_pdf = rays.beta, rays.path, rays.prev_pdf
    q = a // block
    off = a - q * block - 1
    pixel = sample = row = col = 0
    for r in range(a, b):
        off += 1
        if off == block:
            q += 1
            off = 0
        j = j0 + q * step + off
        if r == a or off == 0:
            pixel = j % n_pix
            sample = first_sample + j // n_pix
            row = pixel // width
            col = pixel - row * width
        else:
            pixel += 1
            col += 1
            if pixel == n_pix:
                pixel = row = col = 0
                sample += 1
            elif col == width:
                col = 0
                row += 1
        jx, jy = sobol2(sample, key(key(seed_key, pixel), PAIR_PIXEL))
        dx, dy, dz = camera_ray(camera, col + jx, row + jy)
        o[r, 0], o[r, 1], o[r, 2] = origin[0], origin[1], origin[2]
        d[r, 0], d[r, 1], d[r, 2] = dx, dy, dz
        for c in range(3):
            o32[r, c] = o[r, c]
            d32[r, c] = d[r, c]
            beta[r, c] = 1.0
        path[r] = j
        prev_pdf[r] = 0.0
