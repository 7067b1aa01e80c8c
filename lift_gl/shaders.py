"""GLSL source assembly: `#include` resolution, feature `#define`s, and compile errors mapped
back to the file and line a person wrote.

Every file gets its own block of line numbers through `#line`: line L of file number F is
reported as F * LINE_BLOCK + L. (Source-string numbers would be the natural choice, but
Mesa reports string 0 for some errors.) The driver's log ("0:12(5): error ..." from Mesa,
"0(12) : error ..." from NVIDIA) is translated back to the file and line.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import moderngl

from .bindings import binding_defines
from .errors import ShaderError, read_utf8
from .glsl_arrays import check_array_sizes

REPO_ROOT = Path(__file__).resolve().parent.parent
SHADER_DIR = REPO_ROOT / "shaders"
LIBRARY_DIR = SHADER_DIR / "lift"  # the GLSL library plugins call (docs/glsl-library.md)
GLSL_VERSION = "#version 430"
LINE_BLOCK = 100000

_INCLUDE = re.compile(r'^\s*#\s*include\s+[<"]([^">]+)[">]')
# Mesa: "0:12(5): error: ..."; NVIDIA: "0(12) : error C1008: ..."
_LOG_LINE = re.compile(r"^\s*(?:ERROR:\s*)?(\d+)(?::(\d+)\((\d+)\)|\((\d+)\))\s*:\s*(.*)$")


@dataclass
class ShaderSource:
    """Assembled source plus the table that maps source-string numbers to files."""

    text: str
    files: list[Path] = field(default_factory=list)

    def locate(self, reported_line: int) -> tuple[Path | None, int]:
        number, line = divmod(reported_line, LINE_BLOCK)
        if 0 < number <= len(self.files):
            return self.files[number - 1], line
        return None, reported_line


def _defines_block(defines: dict | None) -> str:
    lines = []
    for name, value in sorted((defines or {}).items()):
        if value is True or value is None:
            lines.append(f"#define {name}")
        elif value is False:
            continue
        else:
            lines.append(f"#define {name} {value}")
    return "\n".join(lines)


def assemble(main: str | Path, defines: dict | None = None, include_dirs=(), *,
             main_name: str = "<generated>") -> ShaderSource:
    """Resolve includes of `main` (a path, or source text named `main_name`).

    Every `#include` is expanded where it stands, also inside `#if` blocks (the assembler
    does not evaluate the preprocessor), so library files need include guards, as all of
    `shaders/lift/` has; an include cycle is an error.

    A file outside shaders/ (a plugin's, a student's) may include only files inside
    `include_dirs`, the folder of a file the host named (`main`, or an include of the
    generated text) or the GLSL library shaders/lift/: never `../../etc/passwd`, nor a link
    that leads out.
    """
    search = [Path(d) for d in include_dirs] + [SHADER_DIR]
    allowed = [d.resolve() for d in include_dirs] + [LIBRARY_DIR]  # for files outside SHADER_DIR
    src = ShaderSource(text="")
    open_files: list[Path] = []  # the include chain being expanded, to catch cycles
    # every program gets the buffer binding points (lift_gl/bindings.py) as LIFT_BINDING_<NAME>
    out: list[str] = [GLSL_VERSION, _defines_block({**binding_defines(), **(defines or {})})]

    def add_file(text: str, path: Path):
        if path not in src.files:
            src.files.append(path)
        number = src.files.index(path) + 1
        out.append(f"#line {number * LINE_BLOCK + 1}")
        for lineno, line in enumerate(text.splitlines(), start=1):
            if line.lstrip().startswith("#version"):
                out.append("")  # the assembler writes the one #version line
                continue
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
            elif SHADER_DIR not in path.parents:
                check_contained(m.group(1), target, allowed, f"GLSL library ({LIBRARY_DIR})", path, lineno)
            if target in open_files:
                raise ShaderError(f'#include "{m.group(1)}" includes itself (through '
                                  f'{" -> ".join(p.name for p in open_files)})', path, lineno)
            open_files.append(target)
            add_file(read_utf8(target, ShaderError), target)
            open_files.pop()
            out.append(f"#line {number * LINE_BLOCK + lineno + 1}")

    if isinstance(main, Path):
        allowed.append(main.resolve().parent)
        open_files.append(main.resolve())
        add_file(read_utf8(main, ShaderError), main.resolve())
    else:
        add_file(main, Path(main_name))
    src.text = "\n".join(out) + "\n"
    return src


def check_contained(include: str, target: Path, allowed: list[Path], library: str, path: Path, lineno: int) -> None:
    """A plugin file's `#include "include"` (found at `target`) must lie inside `allowed`: the
    plugin's folder or the library (GLSL's and OpenCL's assemblers alike)."""
    if not any(_within(target, d) for d in allowed):
        raise ShaderError(f'#include "{include}" is {target}, outside the plugin\'s folder and the {library}: '
                          'a plugin may include only those', path, lineno)


def _within(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _find(name: str, here: Path | None, search: list[Path]) -> Path | None:
    if "\0" in name:  # no file has one (and Path refuses it): not found
        return None
    candidates = ([here / name] if here is not None else []) + [d / name for d in search]
    for c in candidates:
        if c.is_file():
            return c.resolve()
    return None


def parse_log(log: str, source: ShaderSource) -> list[tuple[Path | None, int | None, str]]:
    """(file, line, message) for each error line of a driver's compile log."""
    found = []
    for raw in log.splitlines():
        m = _LOG_LINE.match(raw)
        if not m:
            continue
        path, line = source.locate(int(m.group(2) or m.group(4)))
        found.append((path, line, m.group(5).strip()))
    return found


# A division by a literal zero: `x / 0.0`, `x /= 0`, `x / (0.0)`, `x / vec3(0.0)`. GLSL leaves
# its value unspecified, and llvmpipe's code generator makes it an LLVM undef, which the
# compiler may then read as any value at each use: the NaN/Inf guard cannot see it in every
# shape (a sum over a loop, a conditional return), so the plugin's source is searched for it.
_ZERO = r"(?:0+(?:\.0*)?|\.0+)(?:[eE][+-]?\d+)?[fF]?"
_ZERO_DIVISION = re.compile(rf"/=?\s*(?:{_ZERO}(?![\w.])|\(\s*{_ZERO}\s*\)|"
                            rf"(?:float|double|d?vec[234])\s*\(\s*{_ZERO}\s*\))")
_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)


def constant_zero_divisions(source: ShaderSource) -> list[tuple[Path, int]]:
    """(file, line) of each division by a literal zero in the source's own files: those a
    person wrote (a plugin's), not the library under shaders/ nor the generated host code."""
    found = []
    for path in source.files:
        if not path.is_file() or SHADER_DIR in path.parents:
            continue
        text = _COMMENT.sub(lambda m: "\n" * m.group().count("\n"), path.read_text(errors="replace"))
        for m in _ZERO_DIVISION.finditer(text):
            found.append((path, text.count("\n", 0, m.start()) + 1))
    return found


def compile_compute(ctx: moderngl.Context, source: ShaderSource) -> moderngl.ComputeShader:
    check_array_sizes(source, SHADER_DIR)  # before the compiler, which a huge array hangs
    try:
        return ctx.compute_shader(source.text)
    except moderngl.Error as exc:
        raise _shader_error(str(exc), source) from None


def compile_program(ctx: moderngl.Context, vertex: ShaderSource, fragment: ShaderSource) -> moderngl.Program:
    check_array_sizes(vertex, SHADER_DIR)
    check_array_sizes(fragment, SHADER_DIR)
    try:
        return ctx.program(vertex_shader=vertex.text, fragment_shader=fragment.text)
    except moderngl.Error as exc:
        text = str(exc)
        stage = fragment if "fragment_shader" in text else vertex
        raise _shader_error(text, stage) from None


def _shader_error(log: str, source: ShaderSource) -> ShaderError:
    """The driver's whole log, each line at the file and line it names. The first error's
    place is the error's; Mesa writes one error over several lines at one place (an overload
    that did not match, then each candidate), which stay together under it; the other errors
    follow, each with its own place."""
    entries = parse_log(log, source)
    errors = [e for e in entries if "error" in e[2].lower()] or entries
    if not errors:
        return ShaderError("shader failed to compile:\n" + log)
    places: list[tuple[tuple, list[str]]] = []  # (file, line) and its messages, in the log's order
    for path, line, message in errors:
        if places and places[-1][0] == (path, line):
            # a continuation keeps its indentation (Mesa indents an overload's candidates)
            places[-1][1].append(re.sub(r"^error:(\s)", r"\1", message) if message[6:7].isspace() else message)
        else:
            places.append(((path, line), [message]))
    (path, line), first = places[0]
    text = "\n".join(first)
    for (other_path, other_line), messages in places[1:]:
        where = f"{other_path}:{other_line}: " if other_path is not None else f"line {other_line}: "
        text += "\n" + where + "\n".join(messages)
    return ShaderError(text, path, line)
