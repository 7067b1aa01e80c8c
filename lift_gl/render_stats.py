"""What a renderer reports about its renders so far (Renderer.stats)."""
from __future__ import annotations

from dataclasses import dataclass, field

from .error_estimate import ErrorEstimate
from .passes.common import STAT_DROPPED, STAT_DROPPED_SPLATS, STAT_LOOP_LIMITED, STAT_RAYS_HIGH, STAT_RAYS_LOW


@dataclass
class RenderStats:
    frames: int = 0
    spp: int = 0
    dropped_samples: int = 0
    dropped_splats: int = 0  # plugins with splats = true: splats dropped as NaN/Inf
    loop_limited: int = 0  # pixel-frames whose paths the driver's loop limit cut short
    render_seconds: float = 0.0  # wall time of the frames, I/O excluded
    pass_ms: dict = field(default_factory=dict)  # mean GPU time per pass (with timers=True)
    rays: int = 0  # rays traced through the BVH (with count_rays=True)
    error: ErrorEstimate | None = None  # set by Renderer.estimate_error()
    reprojected: int = 0  # frames that began with a reprojection (temporal="reproject": something moved)
    denoiser: str | None = None  # e.g. "atrous, final frame"; None: not denoised
    denoise_runs: int = 0
    # wall time of the denoiser runs on final images (GPU work finished), inside render_seconds; the
    # per-frame runs of denoise="every" are not waited for (their time: the per-pass timers)
    denoise_seconds: float = 0.0

    def read_counters(self, counters) -> None:
        """Take the GPU's statistics counters (SceneBuffers.read_stats)."""
        self.dropped_samples = int(counters[STAT_DROPPED])
        self.rays = int(counters[STAT_RAYS_LOW]) + (int(counters[STAT_RAYS_HIGH]) << 32)
        self.dropped_splats = int(counters[STAT_DROPPED_SPLATS])
        self.loop_limited = int(counters[STAT_LOOP_LIMITED])

    def summary(self) -> str:
        # The error estimate is the noisy mean's: the denoiser's bias is not in it.
        error = "" if self.error is None else f", est. rel. std. error {100 * self.error.rel_std_error:.2f}%"
        text = (f"{self.spp} spp in {self.render_seconds:.2f} s ({self.frames} frames){error}, "
                f"dropped NaN/Inf samples: {self.dropped_samples}"
                + (f", splats: {self.dropped_splats}" if self.dropped_splats else ""))
        if self.denoiser:
            text += (f"; denoised ({self.denoiser}, {self.denoise_runs} run{'s' if self.denoise_runs != 1 else ''}, "
                     f"{self.denoise_seconds:.3f} s; BIASED: error estimate is of the noisy mean)")
        if self.loop_limited:
            text += (f"; WARNING: in {self.loop_limited} pixel-frames the GL driver's loop limit "
                     "cut paths short (the image is too dark there: lower max_depth, or use a GPU)")
        return text
