"""What `lift-gl render` writes beside an image, as FILE.json: how it was made, how long it
took and how large its error is estimated to be (no reference needed), so that a folder of
renders can be plotted as error against time."""
from __future__ import annotations

import json
from pathlib import Path


def render_record(renderer, scene_path, out_path) -> dict:
    stats = renderer.stats
    record = {"image": str(out_path), "scene": str(scene_path), "integrator": renderer.plugin.name,
              "params": renderer.params, "size": list(renderer.size), "seed": renderer.seed,
              "spp": stats.spp, "frames": stats.frames, "render_seconds": stats.render_seconds,
              "dropped_samples": stats.dropped_samples, "denoise": renderer.denoise_mode}
    if renderer.denoise_mode != "off":
        from .denoise import BIASED

        record.update({"denoiser": renderer.denoiser, "denoise_runs": stats.denoise_runs,
                       "denoise_seconds": stats.denoise_seconds, "biased": BIASED,
                       "error_estimate_of": "the noisy mean, before denoising"})
    if stats.error is not None:
        record.update(stats.error.as_dict())
    from .gl.context import describe

    record["device"] = describe(renderer.ctx)
    return record


def write_render_record(renderer, scene_path, out_path) -> Path:
    """Writes OUT.json beside OUT (e.g. cornell.png.json) and returns its path."""
    path = Path(f"{out_path}.json")
    path.write_text(json.dumps(render_record(renderer, scene_path, out_path), indent=1, default=str) + "\n")
    return path
