"""A plugin folder travels to the workers with its task: the students' folders need not be on
the workers' disks. Each is written once per worker, into a folder named by its content."""
from __future__ import annotations

import hashlib
import tempfile
from pathlib import Path

from ..errors import LiftError

MAX_PLUGIN_BYTES = 16 * 1024 * 1024


def pack_folder(folder) -> dict:
    """The files of a plugin folder: {"name": folder name, "files": {relative path: bytes}}."""
    folder = Path(folder)
    files, total = {}, 0
    for path in sorted(folder.rglob("*")):
        if not path.is_file() or "__pycache__" in path.parts:
            continue
        data = path.read_bytes()
        total += len(data)
        if total > MAX_PLUGIN_BYTES:
            raise LiftError(f"plugin folder holds more than {MAX_PLUGIN_BYTES >> 20} MiB: too much to ship", folder)
        files[str(path.relative_to(folder))] = data
    return {"name": folder.name, "origin": str(folder), "files": files}


def digest(packed: dict) -> str:
    h = hashlib.sha256(packed["name"].encode())
    for name, data in sorted(packed["files"].items()):
        h.update(name.encode() + b"\0" + hashlib.sha256(data).digest())
    return h.hexdigest()[:24]


def unpack_folder(packed: dict, root: Path | None = None) -> Path:
    """The folder on this machine (written the first time); its name is the original's."""
    root = Path(root) if root is not None else Path(tempfile.gettempdir()) / "lift-gl-shipped-plugins"
    home = root / digest(packed)
    folder = home / packed["name"]
    if not folder.is_dir():
        # Written beside, then renamed: another worker of this machine may be unpacking it too.
        home.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(dir=home, prefix=".unpacking-"))
        for name, data in packed["files"].items():
            path = staging / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        try:
            staging.rename(folder)
        except OSError:  # the other one was first: its copy is the same
            import shutil

            shutil.rmtree(staging, ignore_errors=True)
    return folder
