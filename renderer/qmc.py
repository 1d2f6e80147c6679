"""Random numbers for the wavefront: counter-based uniforms and Owen-scrambled Sobol points, in compiled code.

Every uniform a path uses is a pure function of ``(seed, pass, path, bounce, dimension)``, so an image
depends on the seed alone, never on how work was split over threads or batches, and any kernel can draw the
numbers it needs where it needs them (no arrays of uniforms travel between stages).

Pixel positions and light samples use a low-discrepancy sequence instead: the first two dimensions of Sobol's
sequence (a (0, 2)-sequence in base 2), Owen-scrambled by hashing, with the sample index shuffled by the same
kind of scramble (Burley 2020, "Practical Hash-based Owen Scrambling"; the hash is Laine & Karras's, with
Burley's constants). The point of sample ``s`` of a pixel is uniform in the unit square for every ``s`` (so
estimates stay unbiased), and the first ``2^k`` samples of a pixel fall one in each of the ``2^k`` elementary
intervals of every shape: a pixel's samples are stratified at every power of two, progressively. Each pair of
dimensions (pixel, light at bounce 0, light at bounce 1, ...) has its own scramble and shuffle seeds, which
decorrelates them ("padding" by independent shuffles). Other dimensions are independent uniforms.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_M32 = np.uint64(0xFFFFFFFF)
_INV32 = 1.0 / 4294967296.0
_INV53 = 1.0 / 9007199254740992.0


@njit(inline="always", nogil=True, cache=True)
def mix64(x):
    """A 64-bit finalizer (splitmix64's): every input bit affects every output bit."""
    x = np.uint64(x)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@njit(inline="always", nogil=True, cache=True)
def key(a, b):
    """A new key from key ``a`` and a counter ``b``: step ``b + 1`` of the splitmix64 sequence seeded by
    ``a`` (one finalizer; for a well-mixed ``a`` and small counters, independent keys)."""
    return mix64(np.uint64(a) + (np.uint64(b) + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15))


@njit(inline="always", nogil=True, cache=True)
def uniform(k, dim):
    """A uniform double in ``[0, 1)`` for dimension ``dim`` of key ``k`` (a splitmix64 step of its own
    increment, so that no uniform equals a key derived from ``k``)."""
    x = mix64(np.uint64(k) + (np.uint64(dim) + np.uint64(1)) * np.uint64(0xD1B54A32D192ED03))
    return float(x >> np.uint64(11)) * _INV53


@njit(inline="always", nogil=True, cache=True)
def _reverse32(x):
    x = np.uint64(x) & _M32
    x = ((x >> np.uint64(1)) & np.uint64(0x55555555)) | ((x & np.uint64(0x55555555)) << np.uint64(1))
    x = ((x >> np.uint64(2)) & np.uint64(0x33333333)) | ((x & np.uint64(0x33333333)) << np.uint64(2))
    x = ((x >> np.uint64(4)) & np.uint64(0x0F0F0F0F)) | ((x & np.uint64(0x0F0F0F0F)) << np.uint64(4))
    x = ((x >> np.uint64(8)) & np.uint64(0x00FF00FF)) | ((x & np.uint64(0x00FF00FF)) << np.uint64(8))
    return ((x >> np.uint64(16)) | (x << np.uint64(16))) & _M32


@njit(inline="always", nogil=True, cache=True)
def _laine_karras(x, seed):
    """A hash of ``x`` in which each bit depends only on the bits below it (an Owen scramble of reversed bits)."""
    x = (np.uint64(x) + np.uint64(seed)) & _M32
    x ^= (x * np.uint64(0x6C50B47C)) & _M32
    x ^= (x * np.uint64(0xB82F1E52)) & _M32
    x ^= (x * np.uint64(0xC7AFE638)) & _M32
    x ^= (x * np.uint64(0x8D22F6E6)) & _M32
    return x


@njit(inline="always", nogil=True, cache=True)
def owen_scramble(x, seed):
    """Nested uniform (Owen) scramble of the 32-bit ``x``: each bit flipped by a hash of the bits above it."""
    return _reverse32(_laine_karras(_reverse32(x), seed))


def _pascal_bytes() -> np.ndarray:
    """The generator matrix of Sobol's second dimension (Pascal's triangle mod 2: every ``m_k = 1``) as
    byte tables: ``table[b, v]`` is the 32-bit fraction that byte ``b`` of the index, of value ``v``, adds
    (by XOR). The map is linear over GF(2), so four lookups replace a loop over 32 bits."""
    cols = []
    v = 1 << 31
    for _ in range(32):
        cols.append(v)
        v ^= v >> 1
    table = np.zeros((4, 256), dtype=np.uint64)
    for byte in range(4):
        for value in range(256):
            r = 0
            for bit in range(8):
                if value >> bit & 1:
                    r ^= cols[8 * byte + bit]
            table[byte, value] = r
    return table


_SOBOL1 = _pascal_bytes()


@njit(inline="always", nogil=True, cache=True)
def _sobol_dim1(i):
    """The second dimension of Sobol's sequence at index ``i`` as a 32-bit fraction."""
    i = np.uint64(i)
    return (
        _SOBOL1[0, i & np.uint64(0xFF)]
        ^ _SOBOL1[1, (i >> np.uint64(8)) & np.uint64(0xFF)]
        ^ _SOBOL1[2, (i >> np.uint64(16)) & np.uint64(0xFF)]
        ^ _SOBOL1[3, (i >> np.uint64(24)) & np.uint64(0xFF)]
    )


@njit(inline="always", nogil=True, cache=True)
def sobol2(index, k):
    """Point ``index`` of the Owen-scrambled 2D Sobol sequence of key ``k``: ``(x, y)`` in ``[0, 1)^2``.

    The three 32-bit scramble seeds (index shuffle, x, y) are the halves of ``k`` and of its hash. The first
    dimension of Sobol's sequence is the bit reversal of the index, so its Owen scramble
    ``reverse(hash(reverse(reverse(i))))`` needs a single reversal."""
    k = np.uint64(k)
    k2 = mix64(k)
    i = owen_scramble(index, k & _M32)
    x = _reverse32(_laine_karras(i, k >> np.uint64(32)))
    y = owen_scramble(_sobol_dim1(i), k2 & _M32)
    return float(x) * _INV32, float(y) * _INV32


@njit(inline="always", nogil=True, cache=True)
def pair(index, k, low_discrepancy):
    """Two uniforms for sample ``index`` under key ``k``: the Owen-scrambled Sobol point when
    ``low_discrepancy``, else two independent hashes of the key and index."""
    if low_discrepancy:
        return sobol2(index, k)
    j = key(k, index)
    return float(j >> np.uint64(11)) * _INV53, float(mix64(j) >> np.uint64(11)) * _INV53


@njit(nogil=True, cache=True)
def sobol2_points(index, k):
    """``sobol2`` for every index of ``index (n,)``, as an ``(n, 2)`` array (for tests and tools)."""
    n = index.shape[0]
    out = np.empty((n, 2))
    for j in range(n):
        out[j, 0], out[j, 1] = sobol2(index[j], k)
    return out


@njit(nogil=True, cache=True)
def uniforms(keys, dims):
    """``uniform(keys[j], d)`` for ``d < dims``, as an ``(n, dims)`` array."""
    n = keys.shape[0]
    out = np.empty((n, dims))
    for j in range(n):
        for d in range(dims):
            out[j, d] = uniform(keys[j], d)
    return out
