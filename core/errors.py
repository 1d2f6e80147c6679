"""Domain exceptions: every error a user can cause is one of these, with a message a user understands."""

from __future__ import annotations


class BrdfStudioError(Exception):
    """Base class of every user-facing error. The CLI prints the message and exits with ``exit_code``."""

    exit_code = 2


class ParameterError(BrdfStudioError, ValueError):
    """A model parameter is unknown, not a finite number, or outside its bounds."""


class UnknownNameError(BrdfStudioError, KeyError):
    """A model, sampler or other registered name does not exist."""

    def __str__(self) -> str:  # KeyError quotes its message; we want it plain
        return str(self.args[0]) if self.args else ""


class FileFormatError(BrdfStudioError):
    """A file is missing, unreadable, truncated or has the wrong content."""


class OutputError(BrdfStudioError):
    """An output file cannot be written."""


class FormerSamplerName(DeprecationWarning):
    """The notice that a sampler was named by a former name (or with a former option); its message names the
    current name to use. The command line prints it as a ``notice:`` line."""
