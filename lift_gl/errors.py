"""Errors that point at the user's file: one clear message naming the file and line."""
from __future__ import annotations


class LiftError(Exception):
    """Base of every error lift-gl reports to a user."""

    def __init__(self, message: str, path=None, line: int | None = None):
        self.message = message
        self.path = str(path) if path is not None else None
        self.line = line
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            where = self.path + (f":{self.line}" if self.line is not None else "") + ": "
        return where + self.message


class SceneError(LiftError):
    """A scene file that cannot be loaded (syntax, missing mesh, unknown material...)."""


class PluginError(LiftError):
    """A plugin whose manifest is invalid."""


class ShaderError(LiftError):
    """A shader that failed to compile; path and line are of the source file that failed."""
