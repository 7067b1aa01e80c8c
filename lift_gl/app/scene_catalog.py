"""The scenes the viewer's scene picker lists.

- `scenes/` of this repository (the shipped .toml scenes);
- the Lift scenes folder: $LIFT_GL_SCENES (folders separated by os.pathsep) or, by default,
  the course's shared folder beside the repository (`../shared/scenes_lift`, pbrt-v3 files);
- any other file through the path box (or by dropping it on the window).
"""
from __future__ import annotations

import os
from pathlib import Path

from ..plugins import BUILTIN_DIR

REPO_ROOT = BUILTIN_DIR.parent
SCENE_SUFFIXES = (".toml", ".pbrt", ".obj", ".ply", ".glb", ".gltf")


def scene_folders() -> list[Path]:
    env = os.environ.get("LIFT_GL_SCENES", "")
    extra = [Path(d) for d in env.split(os.pathsep) if d]
    return [REPO_ROOT / "scenes"] + (extra or [REPO_ROOT.parent / "shared" / "scenes_lift"])


def find_scenes() -> list[tuple[str, Path]]:
    """(label, path) of every scene in the scene folders: their top level and one level down
    (Lift's layout is NAME/scene.pbrt); the label is the path relative to its folder."""
    found = []
    for folder in scene_folders():
        if not folder.is_dir():
            continue
        candidates = sorted(folder.glob("*")) + sorted(folder.glob("*/*"))
        for path in candidates:
            if path.is_file() and path.suffix.lower() in SCENE_SUFFIXES and not path.name.endswith(".bookmarks.toml"):
                found.append((f"{folder.name}/{path.relative_to(folder).as_posix()}", path))
    return found
