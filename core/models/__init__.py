"""The model library: importing this package registers every model, one line per model module."""

from core.models import lambert  # noqa: F401
