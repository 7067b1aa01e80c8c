"""The GLSL library's reference page, made from the comments in its files:

    python -m lift_gl.glsl_docs > docs/glsl-library.md

Each file of shaders/lift/ gets a section (its header comment), and each public declaration
in it an entry: its signature and the comment written directly above it, the #if it is
compiled under, its struct fields. Names beginning with lift_, Lift or LIFT_ are the library's
internals, u_* uniforms and the buffers are the host's, HAS_* are the host's feature switches:
those are left out, and so are the files of lift/accel/ (the acceleration structures behind
lift/trace.glsl). The path-step contract (LIFT_PATH_STEPS) is documented from
plugins/pt/pt.glsl, the plugin that defines it. tests/test_glsl_docs.py checks that the page
in docs/ is what this makes now.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

from .glsl_library import LIBRARY_DIR, Declaration, LibraryFile, Note, library, parse_file

REPO_ROOT = LIBRARY_DIR.parent.parent
PATH_STEPS_FILE = REPO_ROOT / "plugins" / "pt" / "pt.glsl"
PATH_STEPS_NAMES = ("LIFT_PATH_STEPS", "PathState", "path_start", "path_step", "path_radiance")
INTERNAL_PREFIXES = ("lift_", "Lift", "LIFT_", "u_", "HAS_")
INTERNAL_DIRS = ("accel",)   # folders of shaders/lift/ whose files are the library's internals
# The files a plugin uses most come first; the others follow in alphabetical order.
READING_ORDER = ("surface", "textures", "bsdf", "lights", "trace", "rng", "sampling", "frame", "camera",
                 "scene_data", "fresnel", "microfacet", "emission", "camera_importance", "splat")
KINDS = {"function", "prototype", "struct", "define", "constant", "variable"}


def public(decl: Declaration) -> bool:
    return decl.kind in KINDS and not decl.name.startswith(INTERNAL_PREFIXES)


def documented(f: LibraryFile) -> bool:
    """Whether a library file is on the page: not one of the internals' folders (lift/accel/)."""
    return f.path.parent.name not in INTERNAL_DIRS and any(public(d) for d in f.declarations)


def _markdown(comment: str) -> str:
    """A comment as Markdown: lines that go on a sentence join into paragraphs; indented
    lines (tables, formulas, lists in the comment) keep their layout in a code block; lines
    that begin with `|` are a Markdown table (a file's table of its calls)."""
    out: list[str] = []
    paragraph: list[str] = []
    block: list[str] = []
    table: list[str] = []

    def flush():
        if paragraph:
            out.append(" ".join(paragraph))
            paragraph.clear()
        if block:
            out.append("```\n" + "\n".join(block) + "\n```")
            block.clear()

    for line in comment.splitlines():
        if line.startswith("|"):
            flush()
            table.append(line)
            continue
        if table:
            out.append("\n".join(table))
            table.clear()
        if not line.strip():
            flush()
        elif line.startswith("  ") or (block and line.startswith(" ")):
            if paragraph:
                flush()
            block.append(line)
        else:
            if block:
                flush()
            paragraph.append(line.strip())
    flush()
    if table:
        out.append("\n".join(table))
    return "\n\n".join(out)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _condition_note(conditions: list[str]) -> str:
    """Where the declaration is compiled: '' always (also when its variants cover every case)."""
    distinct = list(dict.fromkeys(conditions))
    if not distinct or "" in distinct:
        return ""
    if len(distinct) == 2 and (distinct[1] in (f"!{distinct[0]}", f"!({distinct[0]})")
                               or distinct[0] in (f"!{distinct[1]}", f"!({distinct[1]})")):
        return ""   # #if X ... #else ...: always, one way or the other
    return "Compiled " + " or ".join(f"with `{c}`" for c in distinct) + "."


def _merge(decls: list[Declaration]) -> list[list[Declaration]]:
    """The declarations of one name together (a prototype and its definition, the branches of
    an #if), in the order of their first appearance."""
    groups: dict[str, list[Declaration]] = {}
    for d in decls:
        groups.setdefault(d.name, []).append(d)
    return list(groups.values())


def _anchor(name: str) -> str:
    """The anchor GitHub gives an entry's heading, `#### `Name``."""
    return name.lower()


def _comment(variants: list[Declaration]) -> str:
    """A name's comment: its definition's, else its prototype's."""
    return next((d.comment for d in sorted(variants, key=lambda d: d.kind == "prototype") if d.comment), "")


def _entry(variants: list[Declaration]) -> str:
    first = variants[0]
    comment = _comment(variants)
    lines = []
    lines.append(f"#### `{first.name}`")  # (the anchor is the name alone: _anchor)
    if first.kind == "struct":
        lines.append(f"```glsl\nstruct {first.name}\n```")
    signatures = list(dict.fromkeys(d.signature + (";" if d.kind != "define" else "") for d in variants
                                    if d.kind != "prototype" or len(variants) == 1))
    if first.kind != "struct":
        lines.append("```glsl\n" + "\n".join(signatures) + "\n```")
    if comment:
        lines.append(_markdown(comment))
    elif first.shares:
        lines.append(f"See [`{first.shares}`](#{_anchor(first.shares)}), declared with it.")
    if first.kind == "struct":
        fields = []
        seen = set()
        for d in variants:
            for f in d.fields:
                if f.name in seen:
                    continue
                seen.add(f.name)
                # a field some of the #if branches leave out: compiled with those that have it
                having = [v.condition for v in variants if any(g.name == f.name for g in v.fields)]
                only = f.condition or ("" if len(having) == len(variants) else " or ".join(having))
                where = f" (with `{only}`)" if only else ""
                fields.append(f"| `{f.name}` | `{f.type}` | {_cell(f.comment)}{where} |")
        lines.append("| field | type | meaning |\n| --- | --- | --- |\n" + "\n".join(fields))
    note = _condition_note([d.condition for d in variants])
    if note:
        lines.append(f"*{note}*")
    return "\n\n".join(lines)


SUMMARY_CHARS = 120


def _summary(comment: str) -> str:
    """The first sentence of a comment (at most SUMMARY_CHARS, cut at a word), for the index."""
    text = " ".join(line.strip() for line in comment.splitlines() if line.strip())
    m = re.match(r"(.+?(?<!\bal)(?<!\be\.g)(?<!\bi\.e)\.)(\s|$)", text)
    sentence = m.group(1) if m else text
    if len(sentence) > SUMMARY_CHARS:
        sentence = sentence[:SUMMARY_CHARS].rsplit(" ", 1)[0].rstrip(",;:(") + " ..."
    return sentence


def _file_section(f: LibraryFile, only: tuple[str, ...] | None = None, heading: str | None = None,
                  intro: str | None = None) -> tuple[str, list[tuple[str, str, str]]]:
    """The Markdown of one file (`only`: just these names; `heading`, `intro`: instead of the
    file's name and header), and (name, file, summary) of each entry for the index."""
    title = f"lift/{f.path.name}" if f.path.parent == LIBRARY_DIR else f.path.relative_to(REPO_ROOT).as_posix()
    parts = [f"## {heading or title}"]
    header = intro if intro is not None else re.sub(r"^(lift/)?[\w.]+\.glsl:\s*", "", f.header)
    header = header[:1].upper() + header[1:]
    if header:
        parts.append(_markdown(header))
    index = []
    wanted = [d for d in f.declarations if public(d) or (only and d.name in only)]
    if only:
        wanted = [d for d in wanted if d.name in only]
    names = {d.name for d in wanted}
    section = None
    pending_notes: list[Note] = []
    done = set()
    for item in f.items:
        if isinstance(item, Note):
            pending_notes.append(item)
            continue
        if item.kind == "block" and item.comment and item.name not in done and not only:
            done.add(item.name)   # a buffer's comment tells the layout of the data it holds
            parts.append(_markdown(item.comment))
            continue
        if item.name not in names or item.name in done:
            continue
        if item.section != section:
            section = item.section
            if section:
                parts.append(f"### {section}")
        for note in pending_notes:
            if note.section == section and not only:
                parts.append(_markdown(note.text))
        pending_notes = []
        done.add(item.name)
        variants = [d for d in wanted if d.name == item.name]
        parts.append(_entry(variants))
        summary = _summary(_comment(variants))
        index.append((item.name, title, summary))
    return "\n\n".join(parts), index


def _ordered(files) -> list[LibraryFile]:
    rank = {name: i for i, name in enumerate(READING_ORDER)}
    return sorted(files, key=lambda f: (rank.get(f.path.stem, len(rank)), f.path.stem))


def generate() -> str:
    files = library()
    host = next((f for f in files if f.path.stem == "host"), None)
    sections, index = [], []
    for f in _ordered(files):
        if not documented(f):
            continue
        text, entries = _file_section(f)
        sections.append(text)
        index += entries
    steps_text, steps_index = _file_section(
        parse_file(PATH_STEPS_FILE), only=PATH_STEPS_NAMES, heading="Path steps (LIFT_PATH_STEPS)",
        intro="A plugin's own functions, not the library's: a plugin that defines `LIFT_PATH_STEPS` and these "
              "lets the host run a frame's samples as one loop over path vertices ([plugins.md](plugins.md) "
              "section 1, [cpu-speed.md](cpu-speed.md)). For each sample the host then calls "
              "`path = path_start(ray, hit)` with the camera ray and its first hit, `path_step(path, rng)` "
              "until it returns false, and takes `path_radiance(path)` as the sample's radiance, where it "
              "would have called `radiance(ray, hit, rng)`. `PathState` may hold only types a storage buffer "
              "can (no samplers or images). `plugins/pt/pt.glsl` defines them; its comments are shown here.")
    # The index: each file's names, linked (their one-line summaries are in the sections).
    by_file: dict[str, list[str]] = {}
    for name, file, _ in index + steps_index:
        by_file.setdefault(file, []).append(name)
    index_rows = "\n".join(f"- `{file}`: " + ", ".join(f"[`{n}`](#{_anchor(n)})" for n in sorted(names, key=str.lower))
                           for file, names in by_file.items())
    intro = ("# The GLSL library\n\n"
             "The functions, structs and constants a plugin's shader can use: `shaders/lift/*.glsl`, all "
             "included before the plugin's code. This page is made from the comments in those files "
             "(`python -m lift_gl.glsl_docs > docs/glsl-library.md`); to change it, change the comments. "
             "[plugins.md](plugins.md) shows how a plugin uses them.\n\n"
             "Conventions: world space unless a name or comment says *local* or *shading frame* (z is the "
             "shading normal; `wo` and `wi` both point away from the surface); radiance is linear RGB; "
             "a `pdf` is a solid-angle density unless it says area. Names beginning with `lift_` or `LIFT_`, "
             "uniforms `u_*` and the buffers are the host's and the library's internals, and are not listed; "
             "nor are the acceleration structures behind `lift/trace.glsl` (`shaders/lift/accel/`).")
    if host is not None and host.header:
        header = re.sub(r"^lift/host\.glsl:\s*", "", host.header)
        intro += "\n\n" + _markdown(header[:1].upper() + header[1:])
    return (intro + "\n\n## Index\n\n" + index_rows + "\n\n"
            + "\n\n".join(sections + [steps_text]) + "\n")


def documented_names() -> set[str]:
    """Every name the page documents."""
    names = {d.name for f in library() if documented(f) for d in f.declarations if public(d)}
    return names | set(PATH_STEPS_NAMES)


def main() -> int:
    sys.stdout.write(generate())
    return 0


if __name__ == "__main__":
    sys.exit(main())
