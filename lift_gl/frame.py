"""One frame of a renderer, pass by pass in the frame graph's order: G-buffer, trace (and a
[reduced] plugin's two passes), reprojection where something moved, accumulation; and the
G-buffer's guides (through the pixel centres) for the denoiser and the AOVs, or the frame's
own G-buffer as the guides where the denoiser runs after every frame."""
from __future__ import annotations

from .frame_passes import GUIDES
from .passes.accumulate import half_sign
from .passes.camera import frame_jitter
from .passes.pixel_filter import filter_uniforms, filtered_jitter
from .passes.reduced_trace import block_offset
from .passes.trace import param_uniforms
from .scene.model import PixelFilter
from .temporal import history_cap


def render_frame(r, samples: int, park: bool = False) -> None:
    """One frame of `samples` per pixel into r's accumulation (Renderer.render_frame)."""
    jitter = filtered_jitter(frame_jitter(r.frame_index, r.seed), r.scene.pixel_filter, r.scene.film_size, r.size)
    # The accumulation's two halves (error estimate) draw from two independent streams.
    stream = 0 if half_sign(r.accumulate.frames) > 0 else 1
    r.buffers.bind()
    gbuffer = r.gbuffer if r.graph.per_frame("gbuffer") else None
    moved, motion = False, None
    if r.reproject is not None:
        moved, motion = r.motion_history.bind(r.packed, r.scene, r.size)
        gbuffer.swap_history()  # this frame's normal and depth go into the older texture
    if gbuffer is not None:
        with r.timed("gbuffer"):
            # Only a [reduced] plugin's passes read more of it than the trace pass's visibility.
            gbuffer.run(r.camera, r.packed.bounds, jitter, r.scene_uniforms, r.camera_uniforms, motion,
                        visibility_only=r.reduced is None and not frame_guides(r))
    uniforms = dict(r.scene_uniforms, **r.camera_uniforms, **param_uniforms(r.plugin, r.params),
                    u_frame=r.frame_index, u_seed=r.seed & 0xFFFFFFFF, u_samples=samples,
                    u_sample_base=r.stream_spp[stream], u_stream=stream, u_jitter=jitter,
                    **filter_uniforms(compiled_pixel_filter(r), r.scene.film_size, r.size))
    if r.prepass is not None:   # a [prepass] plugin's first pass (passes/prepass.py)
        uniforms.update(r.prepass.uniforms(samples))
        with r.timed("prepass"):
            r.prepass.run(uniforms, r.trace.splats)
    with r.timed("trace"):
        r.trace.run(uniforms, gbuffer.visibility if gbuffer is not None else None,
                    park=park and r.reproject is None and r.reduced is None)
    if r.reduced is not None:
        scale = int(r.plugin.reduced.value("scale", r.params))
        offset = block_offset(r.frame_index, scale)
        with r.timed("reduced"):
            r.reduced.run(uniforms, gbuffer, scale, offset)
        with r.timed("upsample"):
            r.upsample.run(r.trace.frame, r.reduced.reduced, gbuffer, scale, offset,
                           r.plugin.reduced.value("normal_power", r.params),
                           r.plugin.reduced.value("depth_sigma", r.params))
    if moved:
        with r.timed("reproject"):
            r.reproject.run(r.accumulate, gbuffer, r.trace.frame, history_cap(r.temporal.min_blend, samples),
                            r.temporal.clamp_sigma)
        r.stats.reprojected += 1
    with r.timed("accumulate"):
        r.accumulate.run(r.trace.frame, late=getattr(r.trace, "late", None))
    if r.reproject is not None:
        r.motion_history.remember(r.scene)
    r.frame_index += 1
    r.stats.frames += 1
    r.stats.spp += samples
    r.stream_spp[stream] += samples


def compiled_pixel_filter(r):
    """The scene's pixel filter; a box over the pixel where the shaders sample one that the
    scene lacks (compiled with every feature, `--all-features`)."""
    if r.scene.pixel_filter is None and r.features.pixel_filter:
        return PixelFilter("box", (0.5, 0.5))
    return r.scene.pixel_filter


def frame_guides(r) -> bool:
    """Whether the denoiser takes its guides from the frame's own G-buffer: denoise="every"
    denoises after each frame, and a second G-buffer a frame cost as much as the first (4-9 ms
    rasterized at 1080p on an H200); the guides are then jittered as the frame's samples."""
    return r.denoise.mode == "every" and r.graph.per_frame("gbuffer")


def guides(r):
    """The G-buffer rendered through the pixel centres (no jitter): the denoiser's guides and
    the AOVs match the image's pixels rather than the last frame's subpixel offset. Made here
    where the frame has no G-buffer (a plugin that traces its own camera rays)."""
    for resource in GUIDES:
        r.graph.ask(resource)
    gbuffer = r.gbuffer
    r.buffers.bind()
    motion = None
    if gbuffer.motion_vectors:
        # Written into the older normal_depth texture, which the next frame overwrites: the
        # previous frame's, which a reprojection needs, is kept.
        _, motion = r.motion_history.bind(r.packed, r.scene, r.size, frame=False)
        gbuffer.swap_history()
    gbuffer.run(r.camera, r.packed.bounds, (0.5, 0.5), r.scene_uniforms, r.camera_uniforms, motion)
    return gbuffer


def guides_done(r) -> None:
    """After guides' textures were read: the frame's own normal and depth are current again,
    and the guides' copy is the older one, which the next frame overwrites."""
    if r.gbuffer.motion_vectors:
        r.gbuffer.swap_history()
