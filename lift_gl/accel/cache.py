"""On-disk cache of BVH builds, so that re-opening a big scene skips the build.

The key is a hash of the exact triangle bytes, their shape and bvh.LAYOUT_VERSION: any change
to the geometry or to the node layout/build gives a different file, so stale entries are
never read (they are simply left behind). A file that cannot be read or fails the sanity
checks is rebuilt and overwritten; the cache is an optimisation and never a reason to fail.
"""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

from .bvh import BVH, LAYOUT_VERSION, build_bvh

ENV_VAR = "LIFT_GL_CACHE_DIR"


def default_cache_dir() -> Path:
    """$LIFT_GL_CACHE_DIR/bvh if set, else ~/.cache/lift-gl/bvh."""
    root = os.environ.get(ENV_VAR)
    if root:
        return Path(root).expanduser() / "bvh"
    return Path.home() / ".cache" / "lift-gl" / "bvh"


def cache_key(tri_positions: np.ndarray) -> str:
    pos = np.ascontiguousarray(tri_positions, dtype=np.float32)
    h = hashlib.blake2b(digest_size=20)
    h.update(LAYOUT_VERSION.encode())
    h.update(repr(pos.shape).encode())
    h.update(pos.reshape(-1).view(np.uint8))
    return h.hexdigest()


def _load(path: Path, n_tris: int) -> BVH | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            nodes, order, depth = z["nodes"], z["order"], int(z["depth"])
            version = str(z["version"])
    except Exception:  # missing, truncated, not a zip, wrong keys...
        return None
    ok = (version == LAYOUT_VERSION and nodes.dtype == np.float32 and nodes.ndim == 2
          and nodes.shape[1] == 8 and nodes.shape[0] >= 1 and order.dtype == np.uint32
          and order.shape == (n_tris,) and 1 <= depth)
    return BVH(nodes=nodes, order=order, depth=depth) if ok else None


def _store(path: Path, bvh: BVH) -> None:
    """Write atomically (temp file + rename) so that a concurrent reader or a crash never
    sees half a file. Failing to write (read-only home, full disk) is not an error."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, nodes=bvh.nodes, order=bvh.order, depth=np.int64(bvh.depth),
                         version=np.str_(LAYOUT_VERSION))
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:
        pass


def cache_path(tri_positions: np.ndarray, cache_dir=None) -> Path:
    root = Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
    return root / f"{cache_key(tri_positions)}.npz"


def build_bvh_cached(tri_positions: np.ndarray, cache_dir=None) -> BVH:
    """build_bvh(tri_positions), read from / written to `cache_dir` (default:
    default_cache_dir())."""
    pos = np.ascontiguousarray(tri_positions, dtype=np.float32)
    path = cache_path(pos, cache_dir)
    bvh = _load(path, pos.shape[0] if pos.ndim == 3 else -1)
    if bvh is None:
        bvh = build_bvh(pos)
        _store(path, bvh)
    return bvh
