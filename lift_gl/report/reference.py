"""The reference image of a comparison: a file (another renderer's converged image), or a
long `pt` render of the same scene, cached on disk.

The cache key hashes everything the image depends on: the packed scene (geometry, BVH,
materials, lights), camera, environment, resolution, sample count, seed, integrator
parameters and the exact shader source compiled (plugin and library, with the feature
defines). Any change gives another file; stale ones are simply left behind.
Cache folder: $LIFT_GL_CACHE_DIR/references, else ~/.cache/lift-gl/references.
"""
from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..accel.cache import default_cache_dir
from ..errors import LiftError
from ..image_io import read_image
from ..metrics import resize_to

REFERENCE_SEED = 0x5EED_F00D  # far from the seeds compare uses (1, 2, ...): independent noise
FORMAT_VERSION = "3"  # 2: the variance of each pixel's mean is kept beside the image; 3: in image order


@dataclass
class Reference:
    image: np.ndarray  # float32 H x W x 3, linear, row 0 at the top
    source: str        # a file path, or "pt, N spp"
    info: dict = field(default_factory=dict)  # how it was made; estimated error when rendered
    cached: bool = False
    # (H, W, 4): the estimated variance of each pixel's mean, R, G, B and luminance, from the
    # render's two halves; None for a file, whose noise is not known (taken as exact)
    variance: np.ndarray | None = None


def reference_cache_dir() -> Path:
    """Beside the BVH cache (accel/cache.py): same root, its own folder."""
    return default_cache_dir().parent / "references"


def load_reference(path, size: tuple[int, int]) -> Reference:
    """A reference file at the render size, box-downsampled if it is an integer multiple."""
    image = read_image(path)
    if not np.isfinite(image).all():
        raise LiftError("the reference holds NaN or infinite values", path)
    h, w = image.shape[:2]
    try:
        image = resize_to(image, (size[1], size[0]))
    except ValueError:
        raise LiftError(f"the reference is {w}x{h}, which does not box-downsample to the render size "
                        f"{size[0]}x{size[1]} (use --size with the same aspect and a whole factor)", path) from None
    return Reference(image=image.astype(np.float32), source=str(path), info={"file": str(path), "file_size": [w, h]})


def reference_key(renderer, spp: int) -> str:
    h = hashlib.sha256()
    h.update(f"lift-gl reference {FORMAT_VERSION}\n".encode())
    packed = renderer.packed
    for name in ("bvh_nodes", "tri_pos", "tri_normal", "tri_uv", "tri_info", "materials", "lights", "spheres"):
        array = np.ascontiguousarray(getattr(packed, name))
        h.update(f"{name} {array.dtype} {array.shape}\n".encode())
        h.update(array.tobytes())
    settings = {"size": list(renderer.size), "spp": spp, "seed": renderer.seed,
                "samples_per_frame": renderer.samples_per_frame, "params": renderer.params,
                "camera": {k: list(v) if isinstance(v, tuple) else v for k, v in renderer.camera_uniforms.items()},
                "scene": {k: list(v) if isinstance(v, tuple) else v for k, v in renderer.scene_uniforms.items()}}
    h.update(json.dumps(settings, sort_keys=True, default=str).encode())
    h.update(renderer.trace.source.text.encode())
    return h.hexdigest()[:32]


def _store(folder: Path, key: str, image: np.ndarray, info: dict, variance: np.ndarray) -> None:
    """Atomic writes (temp file + rename); a cache that cannot be written is not an error."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for suffix, write in ((".npy", lambda f: np.save(f, image)),
                              ("-variance.npz", lambda f: np.savez(f, variance=variance)),
                              (".json", lambda f: f.write(json.dumps(info, indent=1).encode()))):
            fd, tmp = tempfile.mkstemp(dir=folder, prefix=key, suffix=".tmp")
            with os.fdopen(fd, "wb") as f:
                write(f)
            os.replace(tmp, folder / (key + suffix))
    except OSError:
        pass


def _load(folder: Path, key: str, size) -> tuple[np.ndarray, dict, np.ndarray] | None:
    try:
        image = np.load(folder / f"{key}.npy", allow_pickle=False)
        info = json.loads((folder / f"{key}.json").read_text())
        with np.load(folder / f"{key}-variance.npz", allow_pickle=False) as data:
            variance = data["variance"]
    except (OSError, ValueError, KeyError):
        return None
    if image.shape != (size[1], size[0], 3) or image.dtype != np.float32 or not np.isfinite(image).all():
        return None
    if variance.shape != (size[1], size[0], 4):
        return None
    return image, info, variance


def rendered_reference(make_renderer, spp: int, cache_dir=None, progress=None) -> Reference:
    """`spp` samples per pixel of the renderer that `make_renderer(seed)` builds (pt), read
    from the cache when this exact render was made before."""
    renderer = make_renderer(REFERENCE_SEED)
    folder = Path(cache_dir) if cache_dir is not None else reference_cache_dir()
    key = reference_key(renderer, spp)
    found = _load(folder, key, renderer.size)
    if found is not None:
        renderer.release()
        image, info, variance = found
        return Reference(image=image, source=f"{info['integrator']}, {info['spp']} spp", info=info, cached=True,
                         variance=variance)
    start = time.perf_counter()
    image = renderer.render(spp=spp, progress=progress)
    estimate = renderer.estimate_error()
    from .bias import pixel_variance

    variance = pixel_variance(renderer)
    info = {"integrator": renderer.plugin.name, "params": renderer.params, "spp": spp, "seed": renderer.seed,
            "size": list(renderer.size), "render_seconds": renderer.stats.render_seconds,
            "wall_seconds": time.perf_counter() - start, "dropped_samples": renderer.stats.dropped_samples,
            "key": key, "created": time.strftime("%Y-%m-%d %H:%M:%S")}
    if estimate is not None:
        info.update(estimate.as_dict())
    renderer.release()
    if not np.isfinite(image).all():
        raise LiftError("the reference render holds NaN or infinite values")
    _store(folder, key, image, info, variance)
    return Reference(image=image, source=f"{info['integrator']}, {spp} spp", info=info, cached=False,
                     variance=variance)
