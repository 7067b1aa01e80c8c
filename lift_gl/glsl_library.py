"""What the GLSL library (shaders/lift/*.glsl) declares, read from its files: each top-level
function, struct (with its fields), constant, #define and global, with the comment written
directly above it (or after it, on its line), the #if conditions it is compiled under and the
banner section (`// ---- Name ----`) it sits in. The reference page (lift_gl/glsl_docs.py)
and the manifest check of parameter names (lift_gl/plugins.py) are made from this, so they
follow the files as they change.

A light reader, not a compiler: it knows the shapes the library is written in (one
declaration a statement at file level, braces balanced outside comments).
"""
from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from pathlib import Path

LIBRARY_DIR = Path(__file__).resolve().parent.parent / "shaders" / "lift"

_BANNER = re.compile(r"^//\s*[-=]{3,}\s*(.*?)\s*([-=]{3,})?\s*$")   # // ---- Name ----, // ==== Name ====
_GUARD = re.compile(r"^LIFT_\w+_GLSL$")
_QUALIFIERS = r"(?:(?:precise|highp|mediump|lowp|flat|smooth)\s+)*"
_FUNCTION = re.compile(rf"^{_QUALIFIERS}([A-Za-z_]\w*)\s+([A-Za-z_]\w*)\s*\((.*)\)\s*$", re.S)
_VARIABLE = re.compile(r"^((?:(?:const|uniform|shared|coherent|volatile|readonly|writeonly)\s+)*)"
                       r"([A-Za-z_]\w*)\s+([A-Za-z_]\w*)\s*(\[[^\]]*\])?\s*(?:=.*)?$", re.S)
_BLOCK = re.compile(r"^(?:layout\s*\([^)]*\)\s*)?(?:(?:readonly|writeonly|coherent|restrict|volatile)\s+)*"
                    r"(uniform|buffer)\s+([A-Za-z_]\w*)\s*$")
_FIELD = re.compile(r"([A-Za-z_]\w*)\s+([A-Za-z_]\w*(?:\s*\[[^\]]*\])?(?:\s*,\s*[A-Za-z_]\w*(?:\s*\[[^\]]*\])?)*)\s*$")


@dataclass
class Field:
    type: str
    name: str
    comment: str = ""
    condition: str = ""  # the #if it is compiled under inside its struct ('' always)


@dataclass
class Declaration:
    kind: str        # function, prototype, struct, define, constant, variable, uniform, block
    name: str
    signature: str   # its text up to the body: "Surface surface_at(Ray ray, Hit hit)"
    comment: str     # the comment directly above it (or at the end of its line), without //
    path: Path
    line: int
    condition: str = ""  # the #if conditions it is compiled under ('' always)
    section: str = ""    # the banner it follows in its file
    fields: list[Field] = field(default_factory=list)   # structs
    members: list[str] = field(default_factory=list)    # blocks without an instance name: global names
    shares: str = ""     # no comment of its own, on the line after this declaration, whose comment covers both

    @property
    def where(self) -> str:
        """file:line, the file relative to the library's folder (accel/bvh4.glsl)."""
        path = Path(self.path)
        inside = LIBRARY_DIR in path.parents
        return f"{path.relative_to(LIBRARY_DIR).as_posix() if inside else path.name}:{self.line}"


@dataclass
class Note:
    """A comment standing on its own (a blank line below it): it tells about its section."""

    text: str
    section: str = ""


@dataclass
class LibraryFile:
    path: Path
    header: str                   # the comment the file opens with
    items: list                   # Declaration and Note, in the file's order

    @property
    def declarations(self) -> list[Declaration]:
        return [d for d in self.items if isinstance(d, Declaration)]


def _strip_comments(line: str, in_block: bool) -> tuple[str, str, bool]:
    """(code, trailing // or /* */ comment text, still inside a block comment)."""
    if not in_block and "/" not in line:
        return line, "", False
    code, comment, i = [], [], 0
    while i < len(line):
        if in_block:
            end = line.find("*/", i)
            if end < 0:
                comment.append(line[i:])
                return "".join(code), " ".join(c.strip() for c in comment).strip(), True
            comment.append(line[i:end])
            i, in_block = end + 2, False
            continue
        line_comment, block = line.find("//", i), line.find("/*", i)
        if line_comment < 0 and block < 0:
            code.append(line[i:])
            break
        if block < 0 or 0 <= line_comment < block:
            code.append(line[i:line_comment])
            comment.append(line[line_comment + 2:])
            break
        code.append(line[i:block])
        i, in_block = block + 2, True
    return "".join(code), " ".join(c.strip() for c in comment).strip(), in_block


def _condition(stack: list[str]) -> str:
    return " && ".join(c if re.fullmatch(r"!?[\w()]+", c) else f"({c})" for c in stack if c)


def _negation(condition: str) -> str:
    """The #else of an #if on `condition`."""
    if not condition:
        return ""
    if condition.startswith("!") and re.fullmatch(r"!\w+", condition):
        return condition[1:]
    if re.fullmatch(r"\w+", condition):
        return "!" + condition
    return f"!({condition})"


def _if_condition(directive: str, rest: str) -> str:
    rest = rest.strip()
    if directive == "ifdef":
        return rest
    if directive == "ifndef":
        return f"!{rest}"
    return re.sub(r"\s+", " ", rest)   # #if EXPR, #elif EXPR


def parse_file(path: Path) -> LibraryFile:
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines) and (not lines[i].strip() or lines[i].lstrip().startswith("#include")):
        i += 1
    header: list[str] = []
    while i < len(lines) and lines[i].lstrip().startswith("//"):
        header.append(lines[i].lstrip()[2:].removeprefix(" "))
        i += 1
    items: list = []
    pending: list[str] = []   # comment lines directly above the next declaration
    conditions: list[str] = []
    section = ""
    in_block = False

    last = {"decl": None, "end": -1}   # the previous declaration and its last line

    def declare(decl, end):
        previous = last["decl"]
        if not decl.comment and previous is not None and decl.line == last["end"] + 1:
            decl.shares = previous.shares or previous.name   # rng_next2 and rng_next3 under one comment
        last["decl"], last["end"] = decl, end
        items.append(decl)

    while i < len(lines):
        raw = lines[i]
        stripped = raw.strip()
        number = i + 1
        i += 1
        if in_block or stripped.startswith("/*"):
            _, text, in_block = _strip_comments(raw, in_block)
            pending.append(text)
            continue
        if stripped.startswith("//"):
            banner = _BANNER.match(stripped)
            if banner:
                title = banner.group(1)
                # a banner may wrap: its text goes on to the line that ends in dashes
                while banner.group(2) is None and i < len(lines) and lines[i].strip().startswith("//"):
                    more = lines[i].strip()[2:].strip()
                    i += 1
                    end = re.search(r"\s*[-=]{3,}\s*$", more)
                    title += " " + (more[:end.start()] if end else more)
                    if end:
                        break
                if pending:
                    items.append(Note("\n".join(pending).strip(), section))
                section, pending = title.strip(), []
            else:
                pending.append(stripped[2:].removeprefix(" "))
            continue
        if not stripped:
            if any(line.strip() for line in pending):
                items.append(Note("\n".join(pending).strip(), section))
            pending = []
            continue
        if stripped.startswith("#"):
            m = re.match(r"#\s*(\w+)\s*(.*)", stripped)
            directive, rest = (m.group(1), m.group(2)) if m else ("", "")
            if directive in ("if", "ifdef", "ifndef"):
                conditions.append(_if_condition(directive, rest))
                if directive == "ifndef" and _GUARD.match(rest.strip()):
                    conditions[-1] = ""   # the include guard
            elif directive == "elif" and conditions:
                conditions[-1] = _if_condition("if", rest)
            elif directive == "else" and conditions:
                conditions[-1] = _negation(conditions[-1])
            elif directive == "endif" and conditions:
                conditions.pop()
            elif directive == "define":
                code, trailing, _ = _strip_comments(stripped, False)
                while code.rstrip().endswith("\\") and i < len(lines):   # a macro over several lines
                    code = code.rstrip()[:-1] + " " + _strip_comments(lines[i], False)[0].strip()
                    i += 1
                d = re.match(r"#\s*define\s+([A-Za-z_]\w*)(\([^)]*\))?\s*(.*)", code.strip())
                if d and not _GUARD.match(d.group(1)):
                    signature = f"#define {d.group(1)}{d.group(2) or ''} {d.group(3).strip()}".strip()
                    declare(Declaration("define", d.group(1), signature,
                                        "\n\n".join(filter(None, ("\n".join(pending).strip(), trailing))),
                                        Path(path), number, _condition(conditions), section), i)
            pending = pending if directive in ("if", "ifdef", "ifndef", "elif", "else", "endif") else []
            continue
        # A statement at file level: read on to its body's opening brace or its semicolon.
        start = number
        code, trailing, in_block = _strip_comments(raw, False)
        text = code
        while not re.search(r"[{;]", _outside_parens(text)) and i < len(lines):
            more, more_comment, in_block = _strip_comments(lines[i], in_block)
            text += "\n" + more
            trailing = trailing or more_comment
            i += 1
        end = re.search(r"[{;]", _outside_parens(text))
        if end is None:   # the file ended inside a statement
            break
        head, opens = text[:end.start()].strip(), end.group() == "{"
        body_lines = []
        if opens:   # on to the brace that closes the body
            rest = text[end.end():]
            depth = 1 + rest.count("{") - rest.count("}")
            body_lines.append((start, rest, trailing))
            while depth > 0 and i < len(lines):
                more, more_comment, in_block = _strip_comments(lines[i], in_block)
                depth += more.count("{") - more.count("}")
                body_lines.append((i + 1, more, more_comment))
                i += 1
        comment = "\n".join(pending).strip()
        pending = []
        decl = _declaration(head, opens, body_lines, trailing, Path(path), start, _condition(conditions), section,
                            comment)
        if decl is not None:
            declare(decl, i)
    return LibraryFile(Path(path), "\n".join(header).strip(), items)


def _outside_parens(text: str) -> str:
    """`text` with what is inside parentheses blanked out (a layout(...) or argument list may
    hold neither braces nor semicolons that end the statement, but blanking keeps offsets)."""
    out, depth = [], 0
    for ch in text:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        out.append(ch if depth == 0 or ch in "()" else " ")
    return "".join(out)


def _declaration(head, opens, body_lines, trailing, path, line, condition, section, comment):
    head = re.sub(r"\s+", " ", head).strip()
    if not comment and trailing:
        comment = trailing   # struct Ray { ... };   // dir normalized
    m = re.match(r"^struct\s+([A-Za-z_]\w*)$", head)
    if m:
        return Declaration("struct", m.group(1), f"struct {m.group(1)}", comment, path, line, condition, section,
                           fields=_fields(body_lines))
    m = _BLOCK.match(head)
    if m and opens:
        members = [] if _block_instance(body_lines) else [f.name for f in _fields(body_lines)]
        return Declaration("block", m.group(2), head, comment, path, line, condition, section, members=members)
    m = _FUNCTION.match(head)
    if m and m.group(1) not in ("return", "else"):
        arguments = re.sub(r"\s+", " ", m.group(3)).strip()
        signature = f"{m.group(1)} {m.group(2)}({arguments})"
        return Declaration("function" if opens else "prototype", m.group(2), signature, comment, path, line,
                           condition, section)
    m = _VARIABLE.match(head)
    if m and not opens:
        qualifiers = m.group(1).split()
        kind = "uniform" if "uniform" in qualifiers else "constant" if "const" in qualifiers else "variable"
        return Declaration(kind, m.group(3), head, comment, path, line, condition, section)
    return None


def _block_instance(body_lines) -> bool:
    """Whether a block's closing brace is followed by an instance name (its members are then
    not global names)."""
    last = body_lines[-1][1] if body_lines else ""
    return bool(re.search(r"}\s*[A-Za-z_]\w*\s*(\[[^\]]*\])?\s*;", last))


def _fields(body_lines) -> list[Field]:
    """A struct's (or block's) members, each with the comment at the end of its line (and the
    comment-only lines below it, which continue that comment)."""
    fields: list[Field] = []
    conditions: list[str] = []
    for number, (_, code, comment) in enumerate(body_lines):
        if number == 0 and "}" in code:
            comment = ""   # struct Ray { ... };  // a one-line struct's comment is its own
        text = code.strip()
        if text.startswith("#"):
            m = re.match(r"#\s*(\w+)\s*(.*)", text)
            directive, rest = (m.group(1), m.group(2)) if m else ("", "")
            if directive in ("if", "ifdef", "ifndef"):
                conditions.append(_if_condition(directive, rest))
            elif directive == "else" and conditions:
                conditions[-1] = _negation(conditions[-1])
            elif directive == "endif" and conditions:
                conditions.pop()
            continue
        text = text.split("}")[0]
        statements = [s.strip() for s in text.split(";") if s.strip()]
        if not statements:
            if comment and fields:
                fields[-1].comment = (fields[-1].comment + " " + comment).strip()
            continue
        for statement in statements:
            m = _FIELD.search(statement)
            if m:
                for name in m.group(2).split(","):
                    fields.append(Field(m.group(1), re.sub(r"\s+", "", name), comment, _condition(conditions)))
    return fields


@functools.lru_cache(maxsize=4)
def _library(directory: str) -> tuple[LibraryFile, ...]:
    return tuple(parse_file(p) for p in sorted(Path(directory).rglob("*.glsl")))   # lift/accel/ too


def library(directory: Path = LIBRARY_DIR) -> tuple[LibraryFile, ...]:
    """Every file of the library, its subfolders' (lift/accel/) too, parsed (read once a process)."""
    return _library(str(directory))


def library_names(directory: Path = LIBRARY_DIR) -> dict[str, Declaration]:
    """Every name the library declares at file level (functions, structs, #defines, constants,
    globals, uniforms, blocks and the members of blocks without an instance name), each with
    its first declaration."""
    names: dict[str, Declaration] = {}
    for f in library(directory):
        for d in f.declarations:
            names.setdefault(d.name, d)
            for member in d.members:
                names.setdefault(re.sub(r"\[.*", "", member), d)
    return names
