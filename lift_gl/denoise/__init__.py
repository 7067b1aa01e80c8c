"""Denoisers: they take the accumulated radiance and the G-buffer's guides and return a
cleaner radiance image.

A denoiser has a `name` and a method

    denoise(color, albedo, normal, depth=None, variance=None) -> color

on numpy arrays: color, albedo and normal are (H, W, 3) float32 (linear radiance, first-hit
albedo, first-hit normal in world space), depth and variance (H, W) float32 or None. Each
denoiser demodulates by albedo itself (lift_gl/denoise/demodulate.py) where it wants to.
"""
from __future__ import annotations

from ..errors import DenoiserError

DENOISERS = ("atrous", "onnx", "oidn", "glsl")
MODES = ("off", "final", "every")
# The label every denoised output carries (summary line, report, --explain), as biased plugins do.
BIASED = ("the denoiser's output is biased: it trades noise for blur and does not converge to the "
          "integrator's expected value as spp grows")


def get_denoiser(name: str, **options):
    """The denoiser called `name`, its heavy imports done only now.

    atrous: the GLSL à-trous filter (options: ctx, settings or its fields, backend);
    onnx: the trained network (lift_gl/denoise/onnx_denoiser.py; options model_path, ensemble);
    oidn: Intel Open Image Denoise through pyoidn (pip install 'lift-gl[oidn]');
    glsl: the onnx model's graph run by GLSL compute shaders (lift_gl/denoise/glsl_denoiser.py;
    options model_path, ctx, ensemble), needing the onnx package to read the model but not onnxruntime.
    """
    if name == "atrous":
        from .atrous import AtrousDenoiser

        return AtrousDenoiser(**options)
    if name == "onnx":
        try:
            from .onnx_denoiser import OnnxDenoiser
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.onnx_denoiser":
                raise DenoiserError(f"the onnx denoiser needs {exc.name}: pip install onnxruntime") from None
            raise DenoiserError("the onnx denoiser is not part of this build of lift-gl "
                                "(lift_gl/denoise/onnx_denoiser.py is missing); use --denoiser atrous") from None
        return OnnxDenoiser(**options)
    if name == "oidn":
        from .oidn import OidnDenoiser

        return OidnDenoiser(**options)
    if name == "glsl":
        from importlib.util import find_spec

        if find_spec("onnx") is None:  # the model is read on first use; say what is missing now
            raise DenoiserError("the glsl denoiser reads the onnx model with the onnx package: pip install onnx") from None
        from .glsl_denoiser import GlslDenoiser

        return GlslDenoiser(**options)
    raise DenoiserError(f"unknown denoiser {name!r}; choose one of {', '.join(DENOISERS)}")
