"""Camera bookmarks, kept beside the scene as SCENE.bookmarks.toml (e.g. cornell.toml.bookmarks.toml).

    # Camera bookmarks of cornell.toml, written by `lift-gl view`.
    [[bookmark]]
    name = "close-up"
    position = [0.3, 0.8, 2.5]
    target = [0.0, 0.8, 0.0]
    up = [0.0, 1.0, 0.0]
    fov = 30.0              # vertical, degrees
    aperture = 0.0          # lens radius
    focus_distance = 2.5

The file is plain TOML, so it can be edited by hand or kept in version control with a lab
report; a malformed one is reported with its file and line.
"""
from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LiftError
from ..scene.model import Camera

SUFFIX = ".bookmarks.toml"
_VECTORS = ("position", "target", "up")


class BookmarkError(LiftError):
    """A bookmarks file that cannot be read or written."""


@dataclass
class Bookmark:
    name: str
    camera: Camera


def bookmarks_path(scene_path) -> Path:
    scene_path = Path(scene_path)
    return scene_path.with_name(scene_path.name + SUFFIX)


def _line_of_entry(text: str, index: int) -> int | None:
    seen = -1
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip().startswith("[[bookmark]]"):
            seen += 1
            if seen == index:
                return number
    return None


def load_bookmarks(path) -> list[Bookmark]:
    """The bookmarks in a file; [] when there is none."""
    path = Path(path)
    if not path.is_file():
        return []
    text = path.read_text()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        raise BookmarkError(f"malformed TOML: {exc}", path, int(m.group(1)) if m else None) from None
    entries = data.get("bookmark", [])
    if not isinstance(entries, list):
        raise BookmarkError("expected [[bookmark]] tables", path)
    out = []
    for i, entry in enumerate(entries):
        line = _line_of_entry(text, i)
        try:
            vectors = {}
            for key in _VECTORS:
                value = np.asarray(entry.get(key, [0.0, 1.0, 0.0] if key == "up" else None), dtype=np.float64)
                if value.shape != (3,) or not np.isfinite(value).all():
                    raise ValueError(f"{key} must be 3 finite numbers")
                vectors[key] = value
            if np.linalg.norm(vectors["target"] - vectors["position"]) == 0:
                raise ValueError("target equals position")
            fov = float(entry.get("fov", 40.0))
            if not 0 < fov < 180:
                raise ValueError(f"fov {fov} is not in (0, 180)")
            focus = entry.get("focus_distance")
            camera = Camera(position=vectors["position"], target=vectors["target"], up=vectors["up"], fov_deg=fov,
                            aperture_radius=float(entry.get("aperture", 0.0)),
                            focus_distance=None if focus is None else float(focus))
        except (TypeError, ValueError) as exc:
            raise BookmarkError(f"bookmark {i + 1}: {exc}", path, line) from None
        out.append(Bookmark(str(entry.get("name", f"view {i + 1}")), camera))
    return out


def _vector(v) -> str:
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def _string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def save_bookmarks(path, bookmarks: list[Bookmark], scene_name: str = "") -> None:
    path = Path(path)
    lines = [f"# Camera bookmarks of {scene_name or 'a scene'}, written by `lift-gl view`."]
    for b in bookmarks:
        c = b.camera
        lines += ["", "[[bookmark]]", f"name = {_string(b.name)}", f"position = {_vector(c.position)}",
                  f"target = {_vector(c.target)}", f"up = {_vector(c.up)}", f"fov = {float(c.fov_deg)!r}",
                  f"aperture = {float(c.aperture_radius)!r}", f"focus_distance = {float(c.focus)!r}"]
    try:
        path.write_text("\n".join(lines) + "\n")
    except OSError as exc:
        raise BookmarkError(f"cannot write bookmarks: {exc.strerror}", path) from None
