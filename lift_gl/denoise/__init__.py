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
AUTO = "auto"   # the denoiser chosen for the mode and the device (choose_denoiser)
DENOISER_CHOICES = (AUTO,) + DENOISERS
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
    options model_path, ctx, ensemble), needing the onnx package to read the model but
    not onnxruntime. The networks' denoise() also takes previous= and valid= for a temporal
    model (lift_gl/denoise/model_io.py).
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


def choose_denoiser(mode: str, software_gl: bool) -> tuple[str, str]:
    """The denoiser "auto" stands for, and why (--explain): the final image gets the trained
    network, the best of lift-gl's (docs/denoiser.md: SSIM 0.92 against the à-trous filter's 0.81
    on a validation scene at 4 spp), through onnxruntime; every frame of the viewer gets a
    network in GLSL on a GPU (the option realtime_model: the same network by default, 10.9 ms at
    1080p on an H200, or the real-time rt, 2.1 ms) and the à-trous filter on a
    CPU rasterizer, where a network takes seconds a frame."""
    from importlib.util import find_spec

    if mode == "off":
        return "atrous", ""  # nothing runs; the GPU filter needs no package when the mode is switched on
    network_in_glsl = not software_gl and find_spec("onnx") is not None
    if mode == "every":
        if network_in_glsl:
            return "glsl", "every frame on a GPU: the trained network in GLSL compute"
        return "atrous", ("every frame on a CPU rasterizer: the network would take seconds a frame" if software_gl
                          else "every frame: the GLSL network needs the onnx package (pip install onnx)")
    if find_spec("onnxruntime") is not None and find_spec("onnx") is not None:
        return "onnx", "the final image: the trained network, the best denoiser here (docs/denoiser.md)"
    if network_in_glsl:
        return "glsl", "the final image: the trained network in GLSL (onnxruntime is not installed)"
    return "atrous", "the final image: the trained network needs onnxruntime (pip install 'lift-gl[denoise]')"
