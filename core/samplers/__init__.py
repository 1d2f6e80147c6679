"""The old adaptive sampler's temporary home (:mod:`core.samplers.adaptive`), until
:mod:`core.sampling.adaptive` replaces it. The registry of :mod:`core.sampling.base` imports it."""
