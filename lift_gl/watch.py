"""FileWatcher: has any of these files changed since we last looked?

Content hashes, not modification times: two saves within one timestamp tick, or an editor
that restores the old time, still count as a change, and touching a file without changing
it does not. Plugin files are a few kilobytes, so hashing them every frame costs microseconds.
"""
from __future__ import annotations

import hashlib
from pathlib import Path


def _fingerprint(path: Path) -> bytes | None:
    try:
        return hashlib.blake2b(path.read_bytes(), digest_size=16).digest()
    except OSError:  # deleted, or being replaced by an editor: a state of its own
        return None


class FileWatcher:
    def __init__(self, paths=()):
        self.paths: list[Path] = []
        self._seen: dict[Path, bytes | None] = {}
        self.watch(paths)

    def watch(self, paths) -> None:
        """Look at exactly these files from now on. Files already watched keep what was seen
        of them (an edit made meanwhile is still reported); new ones count as seen now."""
        self.paths = sorted({Path(p).resolve() for p in paths})
        self._seen = {p: self._seen[p] if p in self._seen else _fingerprint(p) for p in self.paths}

    def changed(self) -> list[Path]:
        """The files whose contents differ from when they were last seen (and mark them seen)."""
        changed = []
        for path in self.paths:
            now = _fingerprint(path)
            if now != self._seen[path]:
                self._seen[path] = now
                changed.append(path)
        return changed
