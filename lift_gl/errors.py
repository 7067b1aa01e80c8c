"""Errors that point at the user's file: one clear message naming the file and line."""
from __future__ import annotations


class LiftError(Exception):
    """Base of every error lift-gl reports to a user."""

    # True when a loader failed in a way it did not foresee (a bug to fix): the user still
    # gets one clear line, and the fuzz tests (tests/test_fuzz_loaders.py) fail on it.
    internal = False

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


class LimitError(LiftError):
    """An input too large for a fixed or device limit; the message names the limit."""


def read_utf8(path, error=LiftError) -> str:
    """The text of a UTF-8 file (without the byte order mark some editors write), or `error`
    naming the file and the line of the first byte that is not UTF-8 (a binary file, or one
    saved in another encoding)."""
    with open(path, "rb") as f:
        data = f.read()
    try:
        return data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise error(f"not UTF-8 text (byte 0x{data[exc.start]:02x}); save the file as UTF-8",
                    path, line) from None


class DenoiserError(LiftError):
    """A denoiser that cannot run: unknown name, missing optional package or model file."""
