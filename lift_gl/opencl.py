"""OpenCL C for plugins with `language = "opencl"`: the device, source assembly and builds.

pyopencl is imported here and only here, and this module only when such a plugin runs. The
device is the one pyopencl picks (`PYOPENCL_CTX` chooses among several); PoCL runs on any
CPU: `pip install 'lift-gl[opencl]'` installs both.

Sources are assembled like GLSL (shaders.py): every `#include` is inlined once, searched in
the plugin's folder, then in shaders/opencl/ (the shared library, `lift/*.h`). Each file is
marked with `#line N "path"`, so the compiler's messages name the file and line a person
wrote, and the build cache (pyopencl's, PoCL's) keys on the whole text, includes and all.
"""
from __future__ import annotations

import contextlib
import os
import re
import warnings
from pathlib import Path

from .errors import LiftError, ShaderError, read_utf8
from .shaders import SHADER_DIR, ShaderSource, _find, check_contained

CL_LIBRARY_DIR = SHADER_DIR / "opencl"
_INCLUDE = re.compile(r'^\s*#\s*include\s+[<"]([^">]+)[">]')
# clang's "path:line:column: error: message", and PoCL's "error: path:line:column: message"
_LOG_ERRORS = (re.compile(r"^(?P<path>.*?):(?P<line>\d+):(?:\d+:)?\s*(?:fatal )?error:\s*(?P<message>.*)$"),
               re.compile(r"^\s*error:\s*(?P<path>.*?):(?P<line>\d+):(?:\d+:)?\s*(?P<message>.*)$"))

_device = None
_unusable = None  # unusable_reason(): "" once the device works, else why not


class OpenCLError(LiftError):
    """OpenCL is missing or unusable on this machine."""


def import_pyopencl(needed_by=None):
    try:
        import pyopencl
    except ImportError:
        raise OpenCLError("this plugin is written in OpenCL, which needs pyopencl and an OpenCL driver: "
                          "pip install 'lift-gl[opencl]' (pyopencl and PoCL, which runs on the CPU)",
                          needed_by) from None
    return pyopencl


def device(needed_by=None):
    """(context, queue), created once per process."""
    global _device
    if _device is None:
        cl = import_pyopencl(needed_by)
        try:
            context = cl.create_some_context(interactive=False)
        except Exception as exc:  # no platform, or PYOPENCL_CTX names none
            raise OpenCLError(f"no OpenCL device: {exc} (pip install pocl-binary-distribution for the CPU)",
                              needed_by) from None
        _check_compiler(cl, context, needed_by)
        _device = (context, cl.CommandQueue(context))
    return _device


def _check_compiler(cl, context, needed_by) -> None:
    """A device whose compiler refuses a one-line kernel (PoCL's LLVM on a CPU it does not know:
    "unknown target CPU") is unusable: one clear error here rather than at every program."""
    try:
        with _quiet_stderr():
            cl.Program(context, "__kernel void lift_probe(__global float* a) { a[0] = 1.0f; }").build()
    except cl.Error as exc:
        lines = [ln.strip() for ln in str(exc).splitlines() if "error" in ln.lower() and "clBuildProgram" not in ln]
        raise OpenCLError(f"the OpenCL device {context.devices[0].name.strip()!r} cannot compile kernels: "
                          f"{lines[0] if lines else str(exc).splitlines()[0]}", needed_by) from None


def unusable_reason() -> str | None:
    """Why OpenCL cannot run kernels here (pyopencl missing, no device, a compiler that refuses
    a trivial kernel), or None when it can; asked once per process, as device() is made once."""
    global _unusable
    if _unusable is None:
        try:
            device()
            _unusable = ""
        except OpenCLError as exc:
            _unusable = str(exc)
    return _unusable or None


def describe_device() -> str:
    context, _ = device()
    d = context.devices[0]
    return f"{d.platform.name} | {d.name.strip()}"


def assemble(main: str, defines: dict | None = None, include_dirs=(), *, main_name: str = "<generated>") -> ShaderSource:
    """`main` (source text) with its includes inlined once each and `#line` markers. As for
    GLSL (shaders.assemble), a plugin's file may include only files inside `include_dirs`
    (the plugin's folder) or the OpenCL library, links followed."""
    search = [Path(d) for d in include_dirs] + [CL_LIBRARY_DIR]
    allowed = [d.resolve() for d in include_dirs] + [CL_LIBRARY_DIR.resolve()]
    src = ShaderSource(text="")
    seen: set[Path] = set()
    out = [f"#define {name}" if value is True else f"#define {name} {value}"
           for name, value in sorted((defines or {}).items()) if value is not False]

    def add_file(text: str, path: Path):
        src.files.append(path)
        out.append(f'#line 1 "{path.as_posix()}"')
        for lineno, line in enumerate(text.splitlines(), start=1):
            m = _INCLUDE.match(line)
            if not m:
                out.append(line)
                continue
            target = _find(m.group(1), path.parent if path.is_absolute() else None, search)
            if target is None:
                raise ShaderError(f'#include "{m.group(1)}" not found (searched {", ".join(map(str, search))})',
                                  path, lineno)
            if not path.is_absolute():  # the host's generated text: its includes are the host's choice
                allowed.append(target.parent)
            else:
                check_contained(m.group(1), target, allowed, f"OpenCL library ({CL_LIBRARY_DIR})", path, lineno)
            if target not in seen:
                seen.add(target)
                add_file(read_utf8(target, ShaderError), target)
            out.append(f'#line {lineno + 1} "{path.as_posix()}"')

    add_file(main, Path(main_name))
    src.text = "\n".join(out) + "\n"
    return src


def build(source: ShaderSource, needed_by=None):
    """The built program; a compile error becomes a ShaderError naming file and line."""
    cl = import_pyopencl(needed_by)
    context, _ = device(needed_by)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cl.CompilerWarning)  # warnings in the log are not errors
        try:
            with _quiet_stderr():
                return cl.Program(context, source.text).build()
        except cl.RuntimeError as exc:
            raise _build_error(str(exc)) from None


def _build_error(log: str) -> ShaderError:
    errors = []
    for line in log.splitlines():
        m = next(filter(None, (pattern.match(line) for pattern in _LOG_ERRORS)), None)
        if m:
            errors.append(m)
    if not errors:
        return ShaderError("OpenCL build failed:\n" + log)
    first = errors[0]
    more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    return ShaderError(first["message"].strip() + more, first["path"], int(first["line"]))


@contextlib.contextmanager
def _quiet_stderr():
    """The compiler inside PoCL prints "1 error generated." straight to file descriptor 2;
    the build log already holds everything, so keep the user's terminal to one clear line."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    try:
        with open(os.devnull, "wb") as devnull:
            os.dup2(devnull.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
