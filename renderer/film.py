"""The film: a running sum of per-pass radiance estimates, and the mean image they give."""

from __future__ import annotations

import numpy as np


class Film:
    """Accumulates passes of one or more samples per pixel; :meth:`image` is their mean, ``(height, width, 3)``."""

    def __init__(self, width: int, height: int):
        self.width, self.height = width, height
        # the running sum and a scratch array of its shape, allocated by reserve() or the first pass: a job
        # rendered in bands never needs them
        self._sum: np.ndarray | None = None
        self._scratch: np.ndarray | None = None
        self.spp = 0

    def reserve(self) -> None:
        """Allocate and touch the running sum and its scratch array now (a render's preparation), so that the
        first pass does not fault their pages in."""
        self._allocate()

    def _allocate(self) -> tuple[np.ndarray, np.ndarray]:
        if self._sum is None or self._scratch is None:
            self._sum = np.empty((self.height * self.width, 3))
            self._sum.fill(0.0)
            self._scratch = np.empty_like(self._sum)
            self._scratch.fill(0.0)
        return self._sum, self._scratch

    def add_pass(self, radiance: np.ndarray, spp: int = 1) -> None:
        """Add one pass: ``radiance (height * width, 3)``, the mean of ``spp`` samples per pixel."""
        total, scratch = self._allocate()
        total += np.multiply(radiance, spp, out=scratch)
        self.spp += spp

    def image(self) -> np.ndarray:
        """The mean radiance per pixel as float32 ``(height, width, 3)`` (zeros before the first pass)."""
        if self._sum is None or self._scratch is None:
            return np.zeros((self.height, self.width, 3), dtype=np.float32)
        mean = np.divide(self._sum, max(1, self.spp), out=self._scratch)
        return mean.reshape(self.height, self.width, 3).astype(np.float32)
