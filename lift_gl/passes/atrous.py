"""À-trous pass: SVGF's edge-avoiding à-trous wavelet filter on the GPU (shaders/passes/atrous*.comp).

inputs:  irradiance (RGBA32F: demodulated radiance, variance of its luminance; < 0 unknown),
         normal_depth (RGBA32F: the G-buffer's), albedo (any float texture)
outputs: irradiance filtered (ping-pong texture), or radiance (remodulated, RGBA32F with a = 1)

One prepare dispatch (a spatial variance where the half-buffers cannot give one yet), then
`iterations` dispatches of the 5x5 kernel with taps 1, 2, 4, ... pixels apart. Every texture
stays on the GPU; lift_gl/denoise/atrous.py wraps it for numpy images.
"""
from __future__ import annotations

from dataclasses import dataclass

from .. import shaders
from .common import groups, set_uniforms

SHADER_DIR = shaders.SHADER_DIR / "passes"
B3_SPLINE = (1 / 16, 1 / 4, 3 / 8, 1 / 4, 1 / 16)  # the kernel's 1D weights (atrous.comp's KERNEL)


@dataclass(frozen=True)
class AtrousSettings:
    """SVGF's parameters (Schied et al. 2017, section 4.3) and its 5 iterations."""

    iterations: int = 5
    sigma_luminance: float = 4.0  # 0: no luminance edge-stopping
    sigma_normal: float = 128.0   # exponent of n_p . n_q; 0: none
    sigma_depth: float = 1.0      # 0: no depth edge-stopping

    def __post_init__(self):
        if not 1 <= self.iterations <= 10:
            raise ValueError(f"à-trous iterations must be 1..10, not {self.iterations}")
        for name in ("sigma_luminance", "sigma_normal", "sigma_depth"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"à-trous {name} must be >= 0, not {getattr(self, name)}")


class AtrousFilter:
    name = "atrous"
    inputs = ("irradiance", "normal_depth", "albedo")
    outputs = ("radiance",)

    def __init__(self, ctx, size, settings: AtrousSettings | None = None):
        self.ctx = ctx
        self.size = tuple(size)
        self.settings = settings or AtrousSettings()
        self.prepare = shaders.compile_compute(ctx, shaders.assemble(SHADER_DIR / "atrous_prepare.comp"))
        self.iterate = shaders.compile_compute(ctx, shaders.assemble(SHADER_DIR / "atrous.comp"))
        self.remodulate = shaders.compile_compute(ctx, shaders.assemble(SHADER_DIR / "atrous_remodulate.comp"))
        self.ping = ctx.texture(self.size, 4, dtype="f4")
        self.pong = ctx.texture(self.size, 4, dtype="f4")
        self.output = None  # made on the first remodulated run (the numpy wrapper needs none)

    def filter(self, irradiance, normal_depth):
        """Run the iterations on `irradiance`; returns the texture holding the result
        (ping or pong: valid until the next run)."""
        s = self.settings
        normal_depth.use(location=0)
        for program in (self.prepare, self.iterate):
            set_uniforms(program, {"u_normal_depth": 0})
        irradiance.bind_to_image(0, read=True, write=False)
        self.ping.bind_to_image(1, read=False, write=True)
        self.prepare.run(*groups(*self.size))
        source, target = self.ping, self.pong
        set_uniforms(self.iterate, {"u_sigma_luminance": float(s.sigma_luminance),
                                    "u_sigma_normal": float(s.sigma_normal), "u_sigma_depth": float(s.sigma_depth)})
        for i in range(s.iterations):
            self.ctx.memory_barrier()
            self.iterate["u_step"].value = 1 << i
            source.bind_to_image(0, read=True, write=False)
            target.bind_to_image(1, read=False, write=True)
            self.iterate.run(*groups(*self.size))
            source, target = target, source
        self.ctx.memory_barrier()
        return source

    def run(self, irradiance, normal_depth, albedo, albedo_eps: float):
        """Filter and multiply the albedo back: returns `self.output` (radiance, a = 1)."""
        if self.output is None:
            self.output = self.ctx.texture(self.size, 4, dtype="f4")
        result = self.filter(irradiance, normal_depth)
        albedo.use(location=1)
        set_uniforms(self.remodulate, {"u_albedo": 1, "u_albedo_eps": float(albedo_eps)})
        result.bind_to_image(0, read=True, write=False)
        self.output.bind_to_image(1, read=False, write=True)
        self.remodulate.run(*groups(*self.size))
        self.ctx.memory_barrier()
        return self.output

    def release(self) -> None:
        for obj in (self.prepare, self.iterate, self.remodulate, self.ping, self.pong, self.output):
            if obj is not None:
                obj.release()
