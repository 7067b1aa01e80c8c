"""A renderer's settings of what a frame adds to: temporal accumulation and the denoiser.

Unlike the options (lift_gl/options.py, how a frame runs), these change the image: the
reprojection's history and the denoiser are biased, and labelled so.

    Renderer(scene, temporal=TemporalSettings("reproject", min_blend=0.1), denoise="final")
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .denoise import AUTO, DENOISER_CHOICES, DENOISERS, MODES as DENOISE_MODES, choose_denoiser
from .errors import DenoiserError
from .temporal import DEFAULT_MIN_BLEND, MODES as TEMPORAL_MODES, history_cap

MODE_WORDS = {"every": "every frame", "final": "final frame"}


@dataclass(frozen=True)
class TemporalSettings:
    """mode: "reset" (a moved camera or object restarts accumulation) or "reproject" (the
    history is carried over to the new view, docs/temporal.md); min_blend: the least weight a
    moving frame gets; clamp_sigma > 0: the history clamped to the frame's neighbourhood (BIASED)."""
    mode: str = "reset"
    min_blend: float = DEFAULT_MIN_BLEND
    clamp_sigma: float = 0.0

    def __post_init__(self):
        if self.mode not in TEMPORAL_MODES:
            raise ValueError(f"temporal must be one of {', '.join(TEMPORAL_MODES)}, not {self.mode!r}")
        history_cap(self.min_blend, 1)  # validates min_blend
        if not self.clamp_sigma >= 0.0:
            raise ValueError(f"clamp_sigma must be >= 0, not {self.clamp_sigma!r}")
        object.__setattr__(self, "min_blend", float(self.min_blend))
        object.__setattr__(self, "clamp_sigma", float(self.clamp_sigma))

    @classmethod
    def of(cls, value) -> "TemporalSettings":
        """A TemporalSettings, or one of the mode named (a str)."""
        return value if isinstance(value, cls) else cls(mode=value)

    @property
    def reproject(self) -> bool:
        return self.mode == "reproject"


@dataclass(frozen=True)
class DenoiseSettings:
    """mode: "off", "every" (after each frame) or "final" (at the end of each render() call);
    denoiser: "atrous", "onnx", "oidn" or "glsl" (lift_gl.denoise), with its options (the
    à-trous filter's AtrousSettings fields, or get_denoiser's keywords), or "auto" (the
    default: chosen for the mode and the device, lift_gl.denoise.choose_denoiser). BIASED,
    labelled."""
    mode: str = "off"
    denoiser: str = AUTO
    options: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.mode not in DENOISE_MODES:
            raise DenoiserError(f"unknown denoise mode {self.mode!r}; choose one of {', '.join(DENOISE_MODES)}")
        if self.denoiser not in DENOISER_CHOICES:
            raise DenoiserError(f"unknown denoiser {self.denoiser!r}; choose one of {', '.join(DENOISER_CHOICES)}")
        if self.denoiser == AUTO and self.options:
            raise DenoiserError(f"denoiser options {sorted(self.options)} need the denoiser they are for to be named "
                                f"(one of {', '.join(DENOISERS)}), not auto")
        object.__setattr__(self, "options", dict(self.options or {}))

    def resolved(self, software_gl: bool) -> tuple["DenoiseSettings", str]:
        """These settings with "auto" replaced by the denoiser it stands for here, and why
        ("" where the denoiser was named)."""
        if self.denoiser != AUTO:
            return self, ""
        name, why = choose_denoiser(self.mode, software_gl)
        return DenoiseSettings(self.mode, name), why

    @classmethod
    def of(cls, value) -> "DenoiseSettings":
        """A DenoiseSettings, or one of the mode named (a str) with the à-trous filter."""
        return value if isinstance(value, cls) else cls(mode=value)

    @property
    def on(self) -> bool:
        return self.mode != "off"

    def label(self) -> str | None:
        """e.g. "atrous, final frame" (RenderStats.denoiser); None when off."""
        return None if self.mode == "off" else f"{self.denoiser}, {MODE_WORDS[self.mode]}"
