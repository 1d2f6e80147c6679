"""Compiled stages of the wavefront path tracer (:mod:`renderer.integrator`).

A bounce is six loops over the live paths, each one pass over contiguous arrays with no numpy in between:

1. :func:`~renderer.stages.camera.camera_stage` (first bounce only): rays through Owen-scrambled Sobol points
   of each pixel.
2. Embree finds the closest hits (:meth:`renderer.accel.Accel.trace`).
3. :func:`~renderer.stages.hits.hit_stage`: light from the sky on rays that escaped and from emitters that were
   hit (both MIS-weighted against the BRDF sample that made the ray), and the material of every ray that goes
   on.
4. :func:`~renderer.stages.hits.sort_by_material`: the rays that go on, grouped by material (a counting sort),
   so each material's sampler runs once on a contiguous slice; :func:`~renderer.stages.surface.surface_stage`
   computes their frames and one light sample each (area, point or sky), in that order.
5. :func:`~renderer.stages.bsdf.bsdf_stage` (strategies without tables) and the samplers' objects (strategies
   with tables, compiled per strategy outside this package) evaluate ``f`` and their pdf at the light samples
   and draw the BRDF samples, material by material.
6. :func:`~renderer.stages.continuation.continue_stage`: the light sample's MIS-weighted contribution, the
   BRDF sample's throughput and Russian roulette, and the next bounce's rays and the shadow rays, packed; after
   Embree's occlusion test :func:`~renderer.stages.continuation.shadow_stage` adds the unblocked
   contributions.

The stages take their arrays in records (:mod:`renderer.stages.records`: the scene's triangles, lights and
camera, a wavefront's rays, hits, vertices, light and BRDF samples), as pbrt-v4's wavefront work items.

Every stage takes a row range ``[a, b)`` and releases the GIL, so the integrator runs wavefronts on several
threads at once (each wavefront's stages on its thread). The stages allocate nothing (their scratch rows are
the wavefront's, :class:`renderer.wavefront.Buffers`) and are compiled without numba's reference counting
(:func:`core.jit.kernel`): the sky's light sample and lookup, inlined into the loops, took and dropped a
count on each of their arrays per vertex, ~20 % of a pass. Contributions are added to a per-path radiance array
(one row per path; a path belongs to one wavefront), so threads never write the same memory. Random numbers
come from :mod:`renderer.qmc` by key, never from arrays. These kernels do not depend on the material models:
they compile once and are cached.
"""
