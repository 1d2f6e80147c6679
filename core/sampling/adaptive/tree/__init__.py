"""One node's quadtree over the square: built in compiled code, in the steps it takes, a module each.

A tree serves the outgoing directions of one *cell* around its node (:mod:`core.sampling.adaptive.layout`). It
is built from ``g`` (:mod:`core.sampling.adaptive.target`) sampled on each node's 3 x 3 *stencil*: the
corners, the edges' midpoints and the centre of the node's square (Simpson's rule on the stencil gives the
node's integral). The cell is represented by a few *views*: view 0 is the node itself; the others span the
cell (its edges and the points between).

1. :func:`~.grow.grow` (the rejection-free density, :mod:`.grow`). Down to ``base_level`` every node splits;
   below, a leaf splits while its share of the warp's relative variance, ``int_L (g - q)^2 / q`` with ``q``
   the bilinear interpolant of its corners, exceeds ``warp_tol * I``. The leaves' corner values (plus a floor
   of ``FLOOR * I``, so that the density is positive wherever ``f`` can be) define a piecewise-bilinear
   density with exact integrals: the rejection-free mode draws from it and its pdf is exact for its own
   samples.
2. :func:`~.bounds.bound` (the seed's exact mode, :mod:`.bounds`). Every leaf gets ``M_L >= g_view / c_view``
   over the whole cell, ``c`` the exact mode's normalizer as the draws read it (:func:`~.bounds.inv_norm`; the
   table builds it first): the largest value over its stencil at every view, plus a quarter of the largest
   second difference along a line of the stencil (twice what a parabola through them rises between its
   points), plus the lobe's *ridge*: the mirror direction of views across the cell
   (:func:`~.bounds.make_ridge`), and the peak of the node's ``g`` moved with it, clamped into each leaf near
   them (a narrow lobe that moves across the cell passes there); then a safety factor. Then
   :func:`~.probe.probe` (:mod:`.probe`): random points at random views of the cell, and from the best of them
   and the stencils' best a compass climb of the ratio ``g / (c q)`` over the leaf and the cell's views
   (:func:`~.probe._climb`): a peak between the points seen is found where its basin holds a start. A climb
   stalls on a front where ``g`` is cut from a positive value to 0 (the horizon's boundary on a half-vector
   disk, moving with ``wo``): there the ratio is largest on the front's near side, and a leaf's bound can
   still fall short (see ``docs/adaptive.md``, section 4). ``f`` is a black box (model files), so no interval
   or Lipschitz bound is available: the bounds are searched, not proven; every trial with ``g > c M`` is
   counted at run time, the tests assert none (``tests/core/test_adaptive.py``,
   ``tests/core/test_adaptive_bounds.py``) and ``bench/bounds.py`` counts them over every model at six
   ``theta_o`` and three ``phi_o``.
3. :func:`~.bounds.refine` (the seed's ``n_max``). While the envelope's mass ``V = sum area_L M_L`` (in units
   of the normalizer, so the acceptance is ``1 / V`` at every view) exceeds ``n_max / (1 + ACCEPT_MARGIN)``,
   the leaves with the largest excess ``V_L - I_L / c`` are split and bounded again. The seed asks it of every
   leaf (``n_max I_L / V_L >= 1``); the mean number of trials only needs it of the sum, which takes fewer
   leaves.

The steps run in two calls (:mod:`.build`): :func:`shape_tree` (step 1, every leaf's stencils at every view,
and the refinement for the cell's mixture: the rejection-free mode's whole tree) and :func:`bound_tree` (steps
2 and 3, the exact mode's), which continues from the first's :class:`TreeShape`. The table lays its nodes out
with the first and adds the bounds only to the trees it keeps
(:func:`core.sampling.adaptive.table.build_table`).

A tree's own integrals are Simpson sums over its leaves; the normalizer's values, to ``quad_tol``, come from
:func:`view_integral` (step 1's tree for one view, then step 4, :mod:`.quadrature`), at polar angles of their
own.

The compiled steps pass the tree's arrays as records (:mod:`.nodes`): :class:`~.nodes.Target`,
:class:`~.nodes.Nodes`, :class:`~.nodes.CellViews`, :class:`~.nodes.Normalizer`.
"""

from core.sampling.adaptive.tree.bounds import ACCEPT_MARGIN, ANISOTROPIC_BOUND_SAFETY, BOUND_SAFETY, inv_norm
from core.sampling.adaptive.tree.build import (
    BuildSettings,
    TreeArrays,
    TreeShape,
    acceptance,
    bound_tree,
    shape_tree,
)
from core.sampling.adaptive.tree.nodes import FLOOR
from core.sampling.adaptive.tree.quadrature import view_integral

__all__ = [
    "ACCEPT_MARGIN",
    "ANISOTROPIC_BOUND_SAFETY",
    "BOUND_SAFETY",
    "FLOOR",
    "BuildSettings",
    "TreeArrays",
    "TreeShape",
    "acceptance",
    "bound_tree",
    "inv_norm",
    "shape_tree",
    "view_integral",
]
