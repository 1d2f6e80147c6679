"""RGL ``.bsdf`` measured materials (Dupuy & Jakob 2018, "An Adaptive Parameterization for Efficient Material
Acquisition and Rendering"; the RGL material database): the tensor-file container (``tensor_file``), the
compiled warps (``marginal``) and kernels (``lookup``), the material — reading, validation, writing, the
model declarations (``material``) — and the export of any BRDF into the format (``export``).

Import the modules themselves (``from core.rgl.material import rgl_brdf``): this package imports nothing, so
that :mod:`core.dispatch` can reach the kernels without loading the reader and writer.
"""
