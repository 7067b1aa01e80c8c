"""On-disk cache of BVH builds, so that re-opening a big scene skips the build.

The key is a hash of the exact triangle bytes, their shape, the builder and
bvh.LAYOUT_VERSION: any change to the geometry, the builder or the node layout gives a
different file, so stale entries are never read; they are left behind until the folder passes
DEFAULT_MAX_BYTES (4 GiB), when the least recently used go. A file that cannot be read
or fails the sanity checks is rebuilt and overwritten; the cache is an optimisation and never
a reason to fail.
"""
from __future__ import annotations

import hashlib
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .bvh import BVH, LARGE_BINS, LARGE_NODE, LAYOUT_VERSION, SAH_BINS, build_bvh, sah_cost
from .presplit import (AUTO_CANDIDATES, AUTO_MIN_GAIN, OFF, SLIVER_CANDIDATE, SLIVER_TOLERANCE, SplitSettings,
                       presplit, resolve_splits)
from .wide import WideBVH, wide_layout

ENV_VAR = "LIFT_GL_CACHE_DIR"
# sah: binned SAH in numpy (bvh.py); lbvh: Morton-code LBVH through OpenCL (lbvh.py); auto: sah
# below AUTO_LBVH_TRIANGLES, lbvh from there on when pyopencl is installed (the option
# bvh_builder, lift_gl/options.py).
BUILDERS = ("auto", "sah", "lbvh")
AUTO_LBVH_TRIANGLES = 1_000_000
BUILD_NOTICE_TRIANGLES = 50_000   # builds of at least this many triangles are announced on a terminal


def resolve_bins(value: int | str | None = None) -> int | str:
    """The SAH builder's bins per node: a whole number from 8 to 256 (every node that many), or
    'auto' (None, the default): bvh.SAH_BINS, and the tree is built a second time with
    bvh.LARGE_BINS bins for its nodes of bvh.LARGE_NODE triangles or more, and the one of lower
    SAH cost kept (build_with; docs/bvh.md, finer bins at the top)."""
    text = "auto" if value is None else str(value).strip().lower()
    if text == "auto":
        return "auto"
    if not text.isdigit() or not 8 <= int(text) <= 256:
        raise ValueError(f"bad BVH bins {value!r}: use auto or a whole number from 8 to 256")
    return int(text)


def bins_for_one_build(value: int | str | None = None) -> int:
    """The bins of a build made once, for a tree someone waits for (the viewer's live edits):
    resolve_bins's, with auto's second build (finer bins at the top) left out."""
    bins = resolve_bins(value)
    return SAH_BINS if bins == "auto" else bins


def _opencl_available() -> bool:
    import importlib.util

    if importlib.util.find_spec("pyopencl") is None:
        return False
    from ..opencl import unusable_reason  # a device that can compile, not only the package

    return unusable_reason() is None


def resolve_builder(builder: str | None, n_tris: int) -> str:
    """The concrete builder for `builder` (BUILDERS; None: auto)."""
    name = (builder or "auto").strip().lower()
    if name not in BUILDERS:
        raise ValueError(f"unknown BVH builder {name!r}; choose one of {', '.join(BUILDERS)}")
    if name == "auto":
        return "lbvh" if n_tris >= AUTO_LBVH_TRIANGLES and _opencl_available() else "sah"
    return name


def _build_plain(tri_positions: np.ndarray, builder: str, large_bins: int = 0, bins=None) -> BVH:
    if builder == "sah":
        bins = resolve_bins(bins)
        return build_bvh(tri_positions, bins=SAH_BINS if bins == "auto" else bins, large_bins=large_bins)
    from .lbvh import build_lbvh  # pyopencl, only for this builder

    return build_lbvh(tri_positions)


def splits_apply(tri_positions: np.ndarray, splits: SplitSettings) -> bool:
    """Whether `splits` can change this build: static triangles (T, 3, 3) only. A moving
    triangle's box at a time t is refitted from its corners (scene/pack.py), which would undo
    the split boxes, so motion-blurred scenes are built without."""
    return splits.enabled and tri_positions.ndim == 3 and tri_positions.shape[1] == 3 \
        and tri_positions.shape[0] >= splits.min_triangles


def build_with(tri_positions: np.ndarray, builder: str, splits: SplitSettings = OFF, bins=None) -> BVH:
    """Build with a concrete builder name (not auto). With `splits` (accel/presplit.py) large
    triangles enter the build as several references: `order` may then repeat a triangle.
    With `bins` (resolve_bins) auto the SAH tree chosen is built again with finer bins at its
    top (_finer_top)."""
    pos = np.asarray(tri_positions, np.float32)
    prims, ref_tri = pos, None   # what the tree is built over, and each reference's triangle
    split = splits_apply(pos, splits)
    if split and not splits.auto:
        prims, ref_tri = _split_refs(pos, splits) or (prims, ref_tri)
    bvh = _build_plain(prims, builder, bins=bins)
    if split and splits.auto:
        plain_cost = sah_cost(bvh)
        best_cost = plain_cost * (1.0 - AUTO_MIN_GAIN)
        for candidate in AUTO_CANDIDATES:
            refs = _split_refs(pos, candidate)
            if refs is not None and (cost := sah_cost(split := _build_plain(refs[0], builder, bins=bins))) < best_cost:
                (prims, ref_tri), bvh, best_cost = refs, split, cost
        # no candidate kept: slivers alone (as the finer bins, only where the SAH build is the default)
        if splits.slivers and ref_tri is None and pos.shape[0] < AUTO_LBVH_TRIANGLES:
            refs = _split_refs(pos, SLIVER_CANDIDATE)
            if refs is not None and sah_cost(split := _build_plain(refs[0], builder, bins=bins)) \
                    <= plain_cost * (1.0 + SLIVER_TOLERANCE):
                (prims, ref_tri), bvh = refs, split
    bvh = _finer_top(prims, builder, bvh, bins)
    if ref_tri is not None:
        bvh.order = ref_tri[bvh.order].astype(np.uint32)
    return bvh


def _split_refs(pos: np.ndarray, splits: SplitSettings):
    """`splits`' references as build input, (boxes (R, 2, 3), reference -> triangle), or None
    where they split nothing."""
    ref_tri, lo, hi = presplit(pos, splits)
    if ref_tri.size == pos.shape[0]:
        return None
    return np.stack([lo, hi], axis=1), ref_tri  # a box is the box of its 2 corners


def _finer_top(prims: np.ndarray, builder: str, bvh: BVH, bins=None) -> BVH:
    """`bvh`, or the SAH tree over the same primitives built with LARGE_BINS bins for its nodes
    of LARGE_NODE primitives or more, where that one's SAH cost is lower (`bins` auto). Why both: the greedy top-down build sometimes does worse with the finer planes
    (the Bitterli living room's cost 71.1 -> 74.1) and often better (the classroom's 10.3 ->
    8.3); docs/bvh.md "Finer bins at the top"."""
    # scenes of a million primitives or more build once: there the build's own time is what
    # hurts (the size from which the LBVH is the default builder)
    if builder != "sah" or resolve_bins(bins) != "auto" or not LARGE_NODE <= prims.shape[0] < AUTO_LBVH_TRIANGLES:
        return bvh
    finer = _build_plain(prims, builder, large_bins=LARGE_BINS, bins=bins)
    return finer if sah_cost(finer) < sah_cost(bvh) else bvh


def default_cache_dir() -> Path:
    """$LIFT_GL_CACHE_DIR/bvh if set, else ~/.cache/lift-gl/bvh."""
    root = os.environ.get(ENV_VAR)
    if root:
        return Path(root).expanduser() / "bvh"
    return Path.home() / ".cache" / "lift-gl" / "bvh"


def cache_key(tri_positions: np.ndarray, builder: str = "sah", splits: SplitSettings = OFF, bins=None) -> str:
    pos = np.ascontiguousarray(tri_positions, dtype=np.float32)
    h = hashlib.blake2b(digest_size=20)
    h.update(LAYOUT_VERSION.encode())
    if builder != "sah":  # the SAH keys stay what they were before there were other builders
        h.update(builder.encode())
    else:
        h.update(b"axes=all")  # ... and before the SAH builder binned on every axis
        bins = resolve_bins(bins)
        if bins == "auto":   # the finer bins at the top (_finer_top)
            h.update(f"bins={SAH_BINS}+{LARGE_BINS}@{LARGE_NODE}".encode())
        elif bins != SAH_BINS:
            h.update(f"bins={bins}".encode())
    if splits_apply(pos, splits):  # builds that splitting cannot change keep their keys
        h.update(splits.key().encode())
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
    # with splits (presplit.py) `order` repeats triangles: at least one row each
    ok = (version == LAYOUT_VERSION and nodes.dtype == np.float32 and nodes.ndim == 2
          and nodes.shape[1] == 8 and nodes.shape[0] >= 1 and order.dtype == np.uint32
          and order.ndim == 1 and order.shape[0] >= max(n_tris, 0) and 1 <= depth
          and (n_tris <= 0 or (int(order.max()) < n_tris and np.unique(order).size == n_tris)))
    if not ok:
        return None
    _touch(path)
    return BVH(nodes=nodes, order=order, depth=depth)


# The cache's size: after each write, the least recently used files go until the folder holds
# at most this many bytes (`max_bytes` of the functions that write). Each edit of a scene's
# geometry keys a new tree, so a session of live edits to a big scene would otherwise fill the
# disk (a 6.4M-triangle tree and its wide layout take about 300 MB).
DEFAULT_MAX_BYTES = 4 << 30


def _touch(path: Path) -> None:
    """Mark a file read from the cache as recently used (its mtime), for _prune."""
    try:
        os.utime(path)
    except OSError:
        pass


def _prune(root: Path, keep: Path, max_bytes: int = DEFAULT_MAX_BYTES) -> None:
    """Delete the least recently used cache files (oldest mtime first) until the folder holds
    at most `max_bytes`; never `keep`, the file just written. Files another process removes
    first, or cannot be removed, are skipped: the cache is never a reason to fail."""
    try:
        files = []
        for f in root.glob("*.npz"):
            try:
                st = f.stat()
            except OSError:
                continue
            files.append((st.st_mtime, st.st_size, f))
        total, limit = sum(size for _, size, _ in files), max_bytes
        for _, size, f in sorted(files, key=lambda x: x[0]):
            if total <= limit:
                break
            if f == keep:
                continue
            try:
                f.unlink()
                total -= size
            except OSError:
                pass
    except OSError:
        pass


def _store(path: Path, bvh: BVH, max_bytes: int = DEFAULT_MAX_BYTES) -> None:
    _store_arrays(path, max_bytes, nodes=bvh.nodes, order=bvh.order, depth=np.int64(bvh.depth),
                  version=np.str_(LAYOUT_VERSION))


def _store_arrays(path: Path, max_bytes: int = DEFAULT_MAX_BYTES, **arrays) -> None:
    """Write an npz atomically (temp file + rename) so that a concurrent reader or a crash never
    sees half a file. Failing to write (read-only home, full disk) is not an error."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(f, **arrays)
            os.replace(tmp, path)
        except BaseException:
            os.unlink(tmp)
            raise
    except OSError:
        return
    _prune(path.parent, keep=path, max_bytes=max_bytes)


def cache_path(tri_positions: np.ndarray, cache_dir=None, builder: str = "sah",
               splits: SplitSettings = OFF, bins=None) -> Path:
    root = Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
    return root / f"{cache_key(tri_positions, builder, splits, bins)}.npz"


def build_bvh_cached(tri_positions: np.ndarray, cache_dir=None, builder: str | None = None,
                     splits=None, bins=None, max_bytes: int = DEFAULT_MAX_BYTES) -> BVH:
    """The BVH of tri_positions by `builder` (see resolve_builder), with large triangles split
    per `splits` (presplit.resolve_splits: None is auto) and the SAH builder's `bins`
    (resolve_bins: None is auto), read from / written to `cache_dir` (default:
    default_cache_dir()), which keeps to `max_bytes`."""
    pos = np.ascontiguousarray(tri_positions, dtype=np.float32)
    builder = resolve_builder(builder, pos.shape[0] if pos.ndim == 3 else 0)
    splits = resolve_splits(splits)
    bins = resolve_bins(bins)
    path = cache_path(pos, cache_dir, builder, splits, bins)
    bvh = _load(path, pos.shape[0] if pos.ndim == 3 else -1)
    if bvh is None:
        # a scene's first load can take half a minute (the dining room's 270k triangles here):
        # say so on a terminal, where someone is waiting
        notice = pos.shape[0] >= BUILD_NOTICE_TRIANGLES and sys.stderr.isatty()
        if notice:
            print(f"lift-gl: building the BVH of {pos.shape[0]:,} triangles ({builder}); it is cached for next "
                  f"time in {path.parent}", file=sys.stderr, flush=True)
        start = time.perf_counter()
        bvh = build_with(pos, builder, splits, bins)
        if notice:
            print(f"lift-gl: BVH built in {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
        _store(path, bvh, max_bytes)
    return bvh


# The 4-wide layout of a large tree is cached too: the collapse by cost takes seconds on trees of
# millions of nodes (5.2 CPU s for 6.4M triangles on this project's machine), as long again as
# the LBVH build the binary cache saves. Keyed on the binary tree's bytes and every setting
# that shapes the wide one; smaller trees are collapsed each time (under a second).
WIDE_CACHE_MIN_NODES = 1 << 20
WIDE_LAYOUT_VERSION = "wide-1"


def wide_layout_cached(nodes: np.ndarray, layout: str, cache_dir=None, slot_order: str = "area",
                       max_bytes: int = DEFAULT_MAX_BYTES):
    """accel/wide.py wide_layout(nodes, layout, slot_order), read from / written to `cache_dir`
    (default: default_cache_dir()) for trees of at least WIDE_CACHE_MIN_NODES binary nodes."""
    if nodes.shape[0] < WIDE_CACHE_MIN_NODES:
        return wide_layout(nodes, layout, slot_order)
    h = hashlib.blake2b(digest_size=16)
    # ("sah|()": the collapse by cost with its own costs, as the layouts already cached are keyed)
    h.update(f"{WIDE_LAYOUT_VERSION}|{layout}|sah|()|{slot_order}|{nodes.shape!r}".encode())
    h.update(np.ascontiguousarray(nodes, np.float32).view(np.uint8).reshape(-1))
    root = Path(cache_dir).expanduser() if cache_dir is not None else default_cache_dir()
    path = root / f"wide-{h.hexdigest()}.npz"
    try:
        with np.load(path, allow_pickle=False) as z:
            rows, meta = z["rows"], z["meta"]
        if rows.dtype == np.float32 and rows.ndim == 2 and meta.shape == (4,):
            _touch(path)
            return WideBVH(rows=rows, width=int(meta[0]), stack_bound=int(meta[1]), quantized=bool(meta[2]),
                           levels=int(meta[3]))
    except Exception:  # missing, truncated, not a zip, wrong keys...
        pass
    wide = wide_layout(nodes, layout, slot_order)
    if wide is not None:
        _store_arrays(path, max_bytes, rows=wide.rows, meta=np.array([wide.width, wide.stack_bound, int(wide.quantized),
                                                           wide.levels], np.int64))
    return wide
