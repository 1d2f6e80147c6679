"""Sampling strategies beyond the basic ones in :mod:`core.sampler`. Each public module registers its
strategies with :func:`core.sampler.register_sampler`; :func:`core.sampler.make_sampler` imports them on
first use. Adding a strategy is adding a file."""

import importlib
import pkgutil


def load_all() -> None:
    for m in pkgutil.iter_modules(__path__):
        if not m.name.startswith("_"):
            importlib.import_module(f"{__name__}.{m.name}")
