"""The sizes of the arrays a plugin's GLSL declares, read from its source before the GL
compiler sees it: llvmpipe's compiler takes minutes and gigabytes over a large local array
(measured at 8x8 with a dynamic index: 4,096 floats 12 s and 256 MB for the first frame,
16,384 floats 59 s and 640 MB, 65,536 floats 237 s and 2.2 GB), so an array of more than
lift_gl.limits.MAX_SHADER_ARRAY_COMPONENTS scalar components is refused at its file and line.

The assembled text is read as the preprocessor reads it: `#define`, `#undef` and the
`#if`/`#ifdef`/`#ifndef`/`#elif`/`#else` blocks are followed, so a size is the value a
`#define`d name has where the array stands (the host's, a parameter's `define`, the
plugin's own), and arrays in blocks the preprocessor drops are not counted. A size is any
integer constant expression; `T a[N][M]` counts N x M elements of T's components (vec3: 3,
mat4: 16, a struct: its members'). Sizes that are not constant expressions here (a
`const int`, an index `a[i]`) are left to the compiler; a constant index into an array
counts as a size, which can only refuse an index past the limit, out of any array's bounds.
"""
from __future__ import annotations

import ast
import bisect
import re
from pathlib import Path

from .limits import check_shader_array

_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_DIRECTIVE = re.compile(r"^\s*#\s*(\w+)\s*(.*)$")
_LINE = re.compile(r"^(\d+)")
_OBJECT_MACRO = re.compile(r"^([A-Za-z_]\w*)(?:\s+(.*))?$")  # not NAME(args): function-like macros are skipped
_ARRAY = re.compile(r"(?:\[[^\[\]\n]*\]\s*)+")
_SIZE = re.compile(r"\[([^\[\]\n]*)\]")
_INTEGER = re.compile(r"\b(?:0[xX][0-9A-Fa-f]+|\d+)[uU]?\b")
_NAME = re.compile(r"\b[A-Za-z_]\w*\b")
_DEFINED = re.compile(r"\bdefined\s*(?:\(\s*([A-Za-z_]\w*)\s*\)|([A-Za-z_]\w*))")
_STRUCT = re.compile(r"\bstruct\s+([A-Za-z_]\w*)\s*\{([^{}]*)\}")
_MEMBER = re.compile(r"([A-Za-z_]\w*)\s+([^;]+);")
_BEFORE = re.compile(r"(?:\b([A-Za-z_]\w*)\s+)?\b([A-Za-z_]\w*)\s*$")  # `type name` or `type` before [

BUILTIN_COMPONENTS = {t: 1 for t in ("float", "int", "uint", "bool", "double")}
for _n in (2, 3, 4):
    for _prefix in ("", "i", "u", "b", "d"):
        BUILTIN_COMPONENTS[f"{_prefix}vec{_n}"] = _n
    BUILTIN_COMPONENTS[f"mat{_n}"] = BUILTIN_COMPONENTS[f"dmat{_n}"] = _n * _n
    for _m in (2, 3, 4):
        BUILTIN_COMPONENTS[f"mat{_n}x{_m}"] = BUILTIN_COMPONENTS[f"dmat{_n}x{_m}"] = _n * _m


# ---- constant expressions ------------------------------------------------------------------

def _literal(text: str) -> str:
    """A GLSL integer literal (decimal, 0x hex, 0 octal) as Python decimal; kept as it is
    where it is not one (the expression is then not constant)."""
    digits = text.rstrip("uU")
    try:
        value = int(digits, 16) if digits[:2] in ("0x", "0X") else int(
            digits, 8 if len(digits) > 1 and digits[0] == "0" else 10)
    except ValueError:
        return text
    return str(value)


def constant_value(expression: str, macros: dict[str, str], *, undefined_is_zero: bool = False,
                   depth: int = 0) -> int | None:
    """The value of an integer constant expression (C's operators), or None when it is not
    one. In `#if`, names that are not macros are 0 (undefined_is_zero), as in C."""
    if depth > 16:  # a macro that expands into itself
        return None
    unknown = []

    def expand(m):
        name = m.group()
        value = constant_value(macros[name], macros, undefined_is_zero=undefined_is_zero,
                               depth=depth + 1) if name in macros else (0 if undefined_is_zero else None)
        if value is None:
            unknown.append(name)
            return name
        return f"({value})"

    text = _DEFINED.sub(lambda m: "1" if (m.group(1) or m.group(2)) in macros else "0", expression) \
        if undefined_is_zero else expression
    text = _NAME.sub(expand, _INTEGER.sub(lambda m: _literal(m.group()), text))
    if unknown or not text.strip():
        return None
    text = text.replace("&&", " and ").replace("||", " or ").replace("/", "//")
    text = re.sub(r"!(?!=)", " not ", text)
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError:
        return None
    return _evaluate(tree.body)


_BINARY = {ast.Add: lambda a, b: a + b, ast.Sub: lambda a, b: a - b, ast.Mult: lambda a, b: a * b,
           ast.FloorDiv: lambda a, b: a // b if b else None, ast.Mod: lambda a, b: a % b if b else None,
           ast.LShift: lambda a, b: a << b if 0 <= b < 64 else None,
           ast.RShift: lambda a, b: a >> b if 0 <= b < 64 else None,
           ast.BitAnd: lambda a, b: a & b, ast.BitOr: lambda a, b: a | b, ast.BitXor: lambda a, b: a ^ b}
_COMPARE = {ast.Lt: lambda a, b: a < b, ast.LtE: lambda a, b: a <= b, ast.Gt: lambda a, b: a > b,
            ast.GtE: lambda a, b: a >= b, ast.Eq: lambda a, b: a == b, ast.NotEq: lambda a, b: a != b}


def _evaluate(node) -> int | None:
    if isinstance(node, ast.Constant):
        return node.value if type(node.value) is int else None
    if isinstance(node, ast.UnaryOp):
        value = _evaluate(node.operand)
        if value is None:
            return None
        return {ast.USub: -value, ast.UAdd: value, ast.Not: int(not value), ast.Invert: ~value}.get(type(node.op))
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        left, right = _evaluate(node.left), _evaluate(node.right)
        return None if left is None or right is None else _BINARY[type(node.op)](left, right)
    if isinstance(node, ast.BoolOp):
        values = [_evaluate(v) for v in node.values]
        if None in values:
            return None
        return int(all(values) if isinstance(node.op, ast.And) else any(values))
    if isinstance(node, ast.Compare) and len(node.ops) == 1 and type(node.ops[0]) in _COMPARE:
        left, right = _evaluate(node.left), _evaluate(node.comparators[0])
        return None if left is None or right is None else int(_COMPARE[type(node.ops[0])](left, right))
    return None


# ---- the preprocessor's view of the text --------------------------------------------------

def _lines(text: str):
    """(text, kept, macros) for each line of the assembled text: `kept` is whether the
    preprocessor keeps the line, `macros` the names defined there (a new dict after each
    change: the dicts handed out stay as they were). A condition that cannot be evaluated
    here keeps its block (arrays in it count)."""
    macros: dict[str, str] = {}
    stack: list[list[bool]] = []  # per open #if: [this branch taken, a branch was taken]
    for line in _without_comments(text).split("\n"):
        m = _DIRECTIVE.match(line)
        kept = all(frame[0] for frame in stack)
        if m is not None:
            directive, rest = m.group(1), m.group(2).strip()
            if directive in ("if", "ifdef", "ifndef"):
                if directive == "if":
                    value = constant_value(rest, macros, undefined_is_zero=True)
                    taken = True if value is None else bool(value)
                else:
                    taken = (rest.split()[0] in macros) == (directive == "ifdef") if rest else True
                stack.append([taken, taken])
            elif directive in ("elif", "else") and stack:
                frame = stack[-1]
                if frame[1]:
                    frame[0] = False
                else:
                    value = 1 if directive == "else" else constant_value(rest, macros, undefined_is_zero=True)
                    frame[0] = True if value is None else bool(value)
                    frame[1] = frame[0]
            elif directive == "endif" and stack:
                stack.pop()
            elif kept and directive == "define" and _OBJECT_MACRO.match(rest):
                d = _OBJECT_MACRO.match(rest)
                macros = {**macros, d.group(1): (d.group(2) or "").strip()}
            elif kept and directive == "undef" and rest:
                macros = {k: v for k, v in macros.items() if k != rest.split()[0]}
        yield line, kept, macros


def _without_comments(text: str) -> str:
    """Comments blanked, newlines kept (so offsets keep their line numbers)."""
    return _COMMENT.sub(lambda m: re.sub(r"[^\n]", " ", m.group()), text)


# ---- arrays ---------------------------------------------------------------------------------

def _components(type_name: str, structs: dict[str, int]) -> int:
    return BUILTIN_COMPONENTS.get(type_name) or structs.get(type_name, 1)


def _elements(brackets: str, macros: dict[str, str]) -> int | None:
    """N x M of `[N][M]`, or None where a size is not a constant expression."""
    elements = 1
    for size in _SIZE.findall(brackets):
        value = constant_value(size, macros)
        if value is None:
            return None
        elements *= max(value, 1)
    return elements


def _struct_sizes(kept: list[tuple[str, dict]]) -> dict[str, int]:
    """Scalar components of each struct the kept text defines (member arrays included; a
    member of a struct type defined before counts that struct's)."""
    text = "\n".join(line for line, _ in kept)
    starts = [0]
    for line, _ in kept:
        starts.append(starts[-1] + len(line) + 1)
    structs: dict[str, int] = {}
    for m in _STRUCT.finditer(text):
        macros = kept[bisect.bisect_right(starts, m.start()) - 1][1]
        total = 0
        for member_type, declarators in _MEMBER.findall(m.group(2)):
            for declarator in declarators.split(","):
                total += (_elements(declarator, macros) or 1) * _components(member_type, structs)
        structs[m.group(1)] = max(total, 1)
    return structs


def check_array_sizes(source, library_dir: Path) -> None:
    """Raise LimitError at the file and line of the first array in the source's own files
    (those outside `library_dir`: a plugin's, a student's) with more scalar components than
    MAX_SHADER_ARRAY_COMPONENTS."""
    own_files = [p for p in source.files if p.is_absolute() and p.is_file() and library_dir not in p.parents]
    if not any("[" in _without_comments(p.read_text(errors="replace")) for p in own_files):
        return  # most plugins declare no array: the whole text need not be read
    kept, own = [], []  # (line, macros) kept by the preprocessor; and those of the source's own files
    reported = 0  # the line's number as the compiler reports it (#line markers)
    for line, is_kept, macros in _lines(source.text):
        marker = _DIRECTIVE.match(line)
        if marker is not None and marker.group(1) == "line" and _LINE.match(marker.group(2).strip()):
            reported = int(_LINE.match(marker.group(2).strip()).group(1))
            continue
        reported += 1
        if not is_kept or marker is not None:
            continue
        kept.append((line, macros))
        if "[" in line:
            path, file_line = source.locate(reported - 1)
            if path is not None and path.is_absolute() and library_dir not in path.parents:
                own.append((line, macros, path, file_line))
    if not own:
        return
    structs = _struct_sizes(kept) if any("struct" in line for line, _ in kept) else {}
    for line, macros, path, file_line in own:
        for m in _ARRAY.finditer(line):
            elements = _elements(m.group(), macros)
            if elements is None:
                continue
            before = _BEFORE.search(line[:m.start()])
            type_name = ""
            if before is not None:  # `T name[N]`, or `T[N] name` / `T[N](...)`
                last = before.group(2)
                type_name = last if last in BUILTIN_COMPONENTS or last in structs else (before.group(1) or "")
            check_shader_array(elements * _components(type_name, structs), (path, file_line))
