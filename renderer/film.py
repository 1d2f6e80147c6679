"""The film: a running sum of per-pass radiance estimates, and the mean image they give."""

from __future__ import annotations

import numpy as np


class Film:
    """Accumulates passes of one or more samples per pixel; :meth:`image` is their mean, ``(height, width, 3)``."""

    def __init__(self, width: int, height: int):
        self.width, self.height = width, height
        self._sum: np.ndarray | None = (
            None  # allocated by the first pass: a job rendered in bands never needs it
        )
        self._scratch: np.ndarray | None = None
        self.spp = 0

    def reserve(self) -> None:
        """Allocate and touch the running sum and a scratch array now (a render's preparation), so that the
        first pass does not fault their pages in."""
        if self._sum is None:
            self._sum = np.zeros((self.height * self.width, 3))
            self._sum.fill(0.0)
        self._scratch = np.empty_like(self._sum)
        self._scratch.fill(0.0)

    def add_pass(self, radiance: np.ndarray, spp: int = 1) -> None:
        """Add one pass: ``radiance (height * width, 3)``, the mean of ``spp`` samples per pixel."""
        if self._sum is None:
            self._sum = np.zeros((self.height * self.width, 3))
        if self._scratch is None:
            self._sum += radiance * spp
        else:
            self._sum += np.multiply(radiance, spp, out=self._scratch)
        self.spp += spp

    def image(self) -> np.ndarray:
        """The mean radiance per pixel as float32 ``(height, width, 3)`` (zeros before the first pass)."""
        if self._sum is None:
            return np.zeros((self.height, self.width, 3), dtype=np.float32)
        if self._scratch is None:
            mean = self._sum / max(1, self.spp)
        else:
            mean = np.divide(self._sum, max(1, self.spp), out=self._scratch)
        return mean.reshape(self.height, self.width, 3).astype(np.float32)
