"""The one error a BRDF Explorer ``.brdf`` file can cause: its place in the file and what is wrong there."""

from __future__ import annotations

from core.errors import FileFormatError


class ShaderError(FileFormatError):
    """A ``.brdf`` file is malformed: its header, its parameter list or its GLSL shader.

    ``line`` and ``column`` are 1-based and count in the ``.brdf`` file (not in the shader block), so an editor
    can jump to the place; ``column`` is 1 when the whole line is at fault. ``str(error)`` is the single line
    ``"path:line:column: message"``.
    """

    def __init__(self, path: str, line: int, column: int, message: str) -> None:
        self.path = path
        self.line = line
        self.column = column
        self.message = message
        super().__init__(f"{path}:{line}:{column}: {message}")
