"""The adaptive quadtree sampler (Montes 2008): one package, in the steps it takes.

==========  ===================================================================================================
``maps``    the square, the concentric map onto the unit disk, the disk projections
``target``  the function a tree approximates, for one *view* of the material
``tree``    one node's tree, built in compiled code: the rejection-free density, the bounds, ``n_max``,
            the normalizer's quadrature
``layout``  where the nodes are, their cells, the symmetries, the normalizer between nodes
``table``   a material's trees made at once (threads, layout refinement), packed, stored on disk
``draw``    the compiled draws and densities of both modes
``sampler`` the :class:`~core.sampling.base.Sampler`: ``adaptive_exact`` and ``adaptive_warp``
==========  ===================================================================================================

Design, proofs and measurements: ``docs/adaptive.md``.
"""

from core.sampling.adaptive.records import AdaptiveTable, TableOptions
from core.sampling.adaptive.sampler import AdaptiveSampler, clear_memory_cache

__all__ = ["AdaptiveSampler", "AdaptiveTable", "TableOptions", "clear_memory_cache"]
