"""The model library. Importing this package registers every model: each public module here declares one
model (or a family sharing kernels) and calls :func:`core.brdf.declare`. Modules whose name starts with an
underscore, and the shared ``lobes`` module, hold building blocks only. Adding a model is adding a file."""

import importlib
import pkgutil

_ORDER = ["lambert"]  # listed first; the rest follow alphabetically

for _name in _ORDER + sorted(
    m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_") and m.name not in _ORDER
):
    importlib.import_module(f"{__name__}.{_name}")
