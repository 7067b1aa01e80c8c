"""The documentation stays a guide, a reference and design notes of the software as it is: the
README short, docs/ within its size, no page or benchmark file narrating the history of the
work, every relative link and anchor resolving, every picture shown by a page, no stray files."""
from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

from conftest import REPO

README_MAX_LINES = 200
DOCS_MAX_BYTES = 130_000          # the Markdown written by hand under docs/, pictures aside
# Pages generated from the code (lift_gl/reference_docs.py, lift_gl/glsl_docs.py): their size is
# the API's, held by their own freshness tests, not by this guide's budget.
GENERATED_DOCS = ("cli.md", "manifest.md", "options.md", "glsl-library.md")
PICTURE_MAX_BYTES = 150_000
DOCS = REPO / "docs"
# Generated pages whose anchors their own generator and test own (tests/test_glsl_docs.py):
# their links are checked for files only.
ANCHORS_NOT_CHECKED = {DOCS / "glsl-library.md"}
BENCHMARKS = REPO / "benchmarks"
TEXT_SUFFIXES = {".md", ".py", ".sh", ".json", ".csv", ".txt", ".toml", ".svg"}
PICTURE_SUFFIXES = {".png", ".jpg", ".jpeg", ".gif", ".svg"}

ORDINALS = ("first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth|"
            "thirteenth|fourteenth|fifteenth|sixteenth|seventeenth|eighteenth|nineteenth|twentieth")
# What narrates the work instead of describing the software: numbered sessions and rounds of
# work, "the ninth session", result folders named by session, dates of attempts. Numbered
# runs of a measurement ("run 1") and command-line flags (`--rounds 3`) are not history.
HISTORY = [
    re.compile(r"\b(session|round) \d+", re.I),
    re.compile(rf"\b({ORDINALS}|\d+(st|nd|rd|th)|this|next|previous|last|that) session\b", re.I),
    re.compile(r"\bsession_?\d+", re.I),
    re.compile(r"\bclosing run\b", re.I),
    re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b"),
]
# Pages for users cite no issue numbers either ("issue 10 asks ...").
PAGE_HISTORY = HISTORY + [re.compile(r"\bissues? \d+", re.I)]



def _pages() -> list[Path]:
    return [REPO / "README.md", *sorted(DOCS.rglob("*.md")), BENCHMARKS / "README.md"]


def _history(path: Path, patterns) -> list[str]:
    text = path.read_text(encoding="utf-8", errors="replace")
    found = []
    for pattern in patterns:
        for match in pattern.finditer(text):
            line = text.count("\n", 0, match.start()) + 1
            name = path.relative_to(REPO) if path.is_relative_to(REPO) else path.name
            found.append(f"{name}:{line}: {match.group(0)!r}")
    return found


def test_the_readme_is_a_short_guide():
    lines = (REPO / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines, at most {README_MAX_LINES}"
    headings = [line for line in lines if line.startswith("## ")]
    # a newcomer reads what it is, the two commands and how to write a plugin before any numbers
    assert headings[:2] == ["## Two commands", "## Write a plugin"], headings
    plugin_section = "\n".join(lines).split("## Write a plugin", 1)[1].split("\n## ", 1)[0]
    assert "radiance(" in plugin_section and "plugins/template" in plugin_section


def test_docs_stay_within_their_size():
    sizes = {p.relative_to(REPO).as_posix(): p.stat().st_size for p in DOCS.rglob("*.md")
             if p.relative_to(DOCS).as_posix() not in GENERATED_DOCS}
    total = sum(sizes.values())
    largest = ", ".join(f"{name} {size:,}" for name, size in sorted(sizes.items(), key=lambda kv: -kv[1])[:5])
    assert total <= DOCS_MAX_BYTES, f"docs/**/*.md hold {total:,} bytes, at most {DOCS_MAX_BYTES:,} (largest: {largest})"


def test_no_page_narrates_the_history_of_the_work():
    found = [hit for page in _pages() for hit in _history(page, PAGE_HISTORY)]
    assert not found, "history in the docs (say what the software does, with the machine and command):\n" + "\n".join(found)


def test_no_benchmark_file_narrates_the_history_of_the_work():
    found = [hit for path in sorted(p for p in BENCHMARKS.rglob("*") if p.is_file() and p.suffix in TEXT_SUFFIXES)
             for hit in _history(path, HISTORY)]
    assert not found, "history under benchmarks/:\n" + "\n".join(found)


def test_benchmarks_hold_no_patches_and_no_per_run_result_folders():
    patches = [p.relative_to(REPO).as_posix() for p in BENCHMARKS.rglob("*.patch")]
    assert not patches, patches
    results = BENCHMARKS / "results"
    if results.is_dir():
        folders = [p.name for p in results.iterdir() if p.is_dir()]
        assert not [f for f in folders if re.search(r"session|call\d|final|closing|round", f, re.I)], folders


def github_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation but '-' and '_' dropped,
    spaces to '-'."""
    text = re.sub(r"`|\*\*|\*|\[|\]\([^)]*\)", "", heading.strip()).lower()
    text = "".join(c for c in text if c in " -_" or unicodedata.category(c)[0] in "LN")
    return text.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    anchors, seen = set(), {}
    in_code = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_code = not in_code
        if in_code or not re.match(r"#{1,6} ", line):
            continue
        anchor = github_anchor(line.lstrip("#"))
        count = seen.get(anchor, 0)
        seen[anchor] = count + 1
        anchors.add(anchor if count == 0 else f"{anchor}-{count}")
    return anchors


def _links(page: Path):
    text = page.read_text(encoding="utf-8")
    text = re.sub(r"```.*?```", "", text, flags=re.S)       # code blocks hold no links
    text = re.sub(r"`[^`\n]*`", "", text)                  # nor do code spans
    for match in re.finditer(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", text):
        yield match.group(1)


def test_every_relative_link_resolves():
    broken = []
    for page in _pages():
        for target in _links(page):
            if re.match(r"[a-z]+:", target):
                continue                                   # https:, mailto:
            path, _, anchor = target.partition("#")
            resolved = (page.parent / path).resolve() if path else page
            where = f"{page.relative_to(REPO)}: {target}"
            if not resolved.exists():
                broken.append(f"{where} (no such file)")
            elif (anchor and resolved.suffix == ".md" and resolved not in ANCHORS_NOT_CHECKED
                  and anchor not in _anchors(resolved)):
                broken.append(f"{where} (no such heading)")
    assert not broken, "\n".join(broken)


def test_every_picture_in_docs_is_shown_and_small():
    shown = set()
    for page in _pages():
        for target in _links(page):
            shown.add((page.parent / target.partition("#")[0]).resolve())
    pictures = [p for p in DOCS.rglob("*") if p.suffix.lower() in PICTURE_SUFFIXES]
    unshown = [p.relative_to(REPO).as_posix() for p in pictures if p.resolve() not in shown]
    assert not unshown, f"pictures no page shows: {unshown}"
    large = [f"{p.relative_to(REPO)} {p.stat().st_size:,}" for p in pictures if p.stat().st_size > PICTURE_MAX_BYTES]
    assert not large, f"pictures over {PICTURE_MAX_BYTES:,} bytes: {large}"


def test_docs_hold_pages_and_their_pictures_only():
    stray = [p.relative_to(REPO).as_posix() for p in DOCS.rglob("*")
             if p.is_file() and p.suffix.lower() not in PICTURE_SUFFIXES | {".md"}]
    assert not stray, f"files under docs/ that are neither pages nor pictures: {stray}"


@pytest.mark.parametrize("heading, anchor", [
    ("## `lift-gl render`", "lift-gl-render"),
    ("## Coherent sampling (an option)", "coherent-sampling-an-option"),
    ("## Live scene edits (the viewer's F4)", "live-scene-edits-the-viewers-f4"),
    ("### Check a sampling routine: warptest", "check-a-sampling-routine-warptest"),
    ("## À-trous, 5x5", "à-trous-5x5"),
])
def test_anchors_are_githubs(heading, anchor):
    assert github_anchor(heading.lstrip("#")) == anchor


def test_the_link_checker_sees_a_broken_link(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# Title\n\n[a](missing.md) [b](#title) [c](#nothing) `[d](ignored.md)`\n", encoding="utf-8")
    assert list(_links(page)) == ["missing.md", "#title", "#nothing"]
    assert _anchors(page) == {"title"}


def test_the_history_patterns_catch_the_narrative_and_spare_the_flags(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("the ninth session; session 7; results/session17/; 2026-11-26; closing run\n", encoding="utf-8")
    assert len(_history(page, HISTORY)) == 5
    page.write_text("`--rounds 3`, run 1, session.py, a viewer session, 1920x1080\n", encoding="utf-8")
    assert not _history(page, HISTORY)
