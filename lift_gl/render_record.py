"""What `lift-gl render` writes beside an image, as FILE.json: how it was made, how long it
took and how large its error is estimated to be (no reference needed), so that a folder of
renders can be plotted as error against time; and what lift_gl.image_checks found wrong with
it (`warnings`, empty when nothing; `dropped_fraction`, the share of samples dropped as
NaN/Inf); and how its frames ran (`options`: each option's value, what was asked, and why:
lift_gl/options.py)."""
from __future__ import annotations

import json
from pathlib import Path

from .atomic import write_text


def render_record(renderer, scene_path, out_path, warnings=()) -> dict:
    """`warnings`: image_checks.RenderWarning of the render (check_render)."""
    from .image_checks import dropped_fraction

    stats = renderer.stats
    record = {"image": str(out_path), "scene": str(scene_path), "integrator": renderer.plugin.name,
              "params": renderer.params, "size": list(renderer.size), "seed": renderer.seed,
              "spp": stats.spp, "frames": stats.frames, "render_seconds": stats.render_seconds,
              "dropped_samples": stats.dropped_samples,
              "dropped_fraction": dropped_fraction(stats, renderer.size[0] * renderer.size[1]),
              "warnings": [w.as_dict() for w in warnings], "denoise": renderer.denoise_mode}
    if renderer.denoise_mode != "off":
        from .denoise import BIASED

        record.update({"denoiser": renderer.denoiser, "denoise_runs": stats.denoise_runs,
                       "denoise_seconds": stats.denoise_seconds, "biased": BIASED,
                       "error_estimate_of": "the noisy mean, before denoising"})
    if stats.error is not None:
        record.update(stats.error.as_dict())
    from .gl.context import describe

    record["device"] = describe(renderer.ctx)
    record["options"] = renderer.choices.record()
    return record


def write_render_record(renderer, scene_path, out_path, warnings=()) -> Path:
    """Writes OUT.json beside OUT (e.g. cornell.png.json) and returns its path."""
    path = Path(f"{out_path}.json")
    record = render_record(renderer, scene_path, out_path, warnings)
    write_text(path, json.dumps(record, indent=1, default=str) + "\n")
    return path
