"""OpenGL 4.3+ contexts without a window: EGL (default) or OSMesa.

`auto` tries EGL first (Mesa llvmpipe on a CPU machine, the vendor driver on a GPU machine)
and falls back to OSMesa. Both give a core-profile context in which compute shaders run.
"""
from __future__ import annotations

import ctypes
import ctypes.util

import moderngl

from ..errors import LiftError

BACKENDS = ("auto", "egl", "osmesa")
REQUIRED_GL = 430


class ContextError(LiftError):
    pass


_contexts: dict[str, moderngl.Context] = {}


def create_context(backend: str = "auto") -> moderngl.Context:
    """A headless context of the given backend; one per backend and process, reused."""
    if backend not in BACKENDS:
        raise ContextError(f"unknown GL backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if backend in _contexts:
        return _contexts[backend]
    if backend == "auto":
        errors = []
        for candidate in ("egl", "osmesa"):
            try:
                ctx = create_context(candidate)
            except ContextError as exc:
                errors.append(str(exc))
                continue
            _contexts["auto"] = ctx
            return ctx
        raise ContextError("no headless OpenGL 4.3 context could be created:\n  " + "\n  ".join(errors)
                           + "\n  install the Debian packages libegl1 libegl-mesa0 libgl1-mesa-dri libosmesa6")
    ctx = new_context(backend)
    _contexts[backend] = ctx
    return ctx


def new_context(backend: str) -> moderngl.Context:
    """A context of its own ("egl" or "osmesa"), not shared, current on the calling thread: for
    a thread that renders beside the main one (the notebook widget, lift_gl/notebook/)."""
    if backend == "auto":
        errors = []
        for candidate in ("egl", "osmesa"):
            try:
                return new_context(candidate)
            except ContextError as exc:
                errors.append(str(exc))
        raise ContextError("no headless OpenGL 4.3 context could be created:\n  " + "\n  ".join(errors))
    ctx = _create_egl() if backend == "egl" else _create_osmesa()
    ctx.extra = {"backend": backend}
    return ctx


def _create_egl() -> moderngl.Context:
    try:
        return moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL)
    except Exception as exc:  # glcontext raises plain Exceptions
        raise ContextError(f"EGL: {exc}") from None


# --- OSMesa --------------------------------------------------------------------------------
OSMESA_FORMAT = 0x22
OSMESA_RGBA = 0x1908
OSMESA_DEPTH_BITS = 0x30
OSMESA_PROFILE = 0x33
OSMESA_CORE_PROFILE = 0x34
OSMESA_CONTEXT_MAJOR_VERSION = 0x36
OSMESA_CONTEXT_MINOR_VERSION = 0x37
GL_UNSIGNED_BYTE = 0x1401


class _OSMesaLoader:
    """What moderngl.init_context needs: a function pointer for each GL entry point."""

    def __init__(self, lib):
        self._lib = lib

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode()) or 0

    def release(self):
        pass


def _load_osmesa():
    names = [ctypes.util.find_library("OSMesa"), "libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"]
    for name in filter(None, names):
        try:
            return ctypes.CDLL(name)
        except OSError:
            continue
    raise ContextError("OSMesa: libOSMesa not found (Debian package libosmesa6)")


_osmesa_keepalive = []


def _create_osmesa() -> moderngl.Context:
    lib = _load_osmesa()
    lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
    lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
    lib.OSMesaMakeCurrent.restype = ctypes.c_ubyte
    lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint, ctypes.c_int, ctypes.c_int]
    lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
    lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
    attribs = (ctypes.c_int * 11)(
        OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
        OSMESA_CONTEXT_MAJOR_VERSION, 4, OSMESA_CONTEXT_MINOR_VERSION, 5, 0)
    handle = lib.OSMesaCreateContextAttribs(attribs, None)
    if not handle:
        raise ContextError("OSMesa: could not create a core 4.5 context")
    # The default framebuffer is unused (we render to textures) but must exist to be current.
    size = 4
    buffer = (ctypes.c_ubyte * (size * size * 4))()
    if not lib.OSMesaMakeCurrent(handle, buffer, GL_UNSIGNED_BYTE, size, size):
        raise ContextError("OSMesa: OSMesaMakeCurrent failed")
    _osmesa_keepalive.append((lib, handle, buffer))
    try:
        moderngl.init_context(loader=_OSMesaLoader(lib))
        ctx = moderngl.get_context()
    except Exception as exc:
        raise ContextError(f"OSMesa: {exc}") from None
    if ctx.version_code < REQUIRED_GL:
        raise ContextError(f"OSMesa: OpenGL {ctx.version_code} < {REQUIRED_GL}")
    return ctx


def describe(ctx: moderngl.Context) -> str:
    info = ctx.info
    backend = getattr(ctx, "extra", None) or {}
    return f"{info['GL_RENDERER']} | {info['GL_VERSION']} | {backend.get('backend', '?')}"


SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast")


def is_software(ctx: moderngl.Context) -> bool:
    """True on a CPU rasterizer (Mesa llvmpipe): no GPU, and timer queries are not to be trusted."""
    return any(name in ctx.info["GL_RENDERER"].lower() for name in SOFTWARE_RENDERERS)
