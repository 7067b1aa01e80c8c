"""Fuzzing the loaders: one generic harness for every file format lift-gl reads.

A loader under fuzz is a row of LOADERS: a name, the file name the fuzzed input is written
to (its suffix picks the format), the function that loads it, the seed files whose mutations
are tried, and the files each seed needs beside it (meshes, included files, a plugin's
shader). Adding a format is one row.

The property (check_input): loading any input — a seed truncated anywhere, mutated by a few
edits that insert hostile tokens, or random bytes — either succeeds, and the result packs
into finite GPU arrays, or ends in exactly one LiftError (SceneError, PluginError,
LimitError) that names a file and reads as one line, and that the loader did not mark as an
internal failure. Any other exception escapes and fails the run.

Used by tests/test_fuzz_loaders.py (a few hundred derandomized cases per loader, through
hypothesis) and benchmarks/fuzz_loaders.py (many more, counted, for the report).
"""
from __future__ import annotations

import random
import re
import shutil
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from lift_gl.errors import LiftError
from lift_gl.plugins import load_manifest
from lift_gl.scene.loader import load_scene
from lift_gl.scene.model import Scene
from lift_gl.scene.pack import pack_scene

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "scenes"
DATA = REPO / "tests" / "data"


def seeds(folder: Path, pattern: str) -> list[Path]:
    return sorted(folder.glob(pattern))


def self_contained(paths: list[Path]) -> list[Path]:
    """Seeds whose files lie beside them (covered_dragon.toml's mesh is in ../shared)."""
    return [p for p in paths if '"../' not in p.read_text(errors="replace")]


def load_plugin_folder(path: Path):
    return load_manifest(path.parent)


@dataclass
class Fuzzed:
    name: str
    filename: str
    load: Callable[[Path], object]
    seeds: list[Path]
    # Files copied beside every input, so that mutations of a seed still find what it refers
    # to (and mutate around real meshes and includes rather than only missing ones).
    siblings: list[Path] = field(default_factory=list)


LOADERS = [
    Fuzzed("TOML scene", "scene.toml", load_scene,
           self_contained(seeds(SCENES, "*.toml") + seeds(SCENES / "stress", "*.toml") + seeds(DATA, "*.toml")),
           siblings=seeds(SCENES / "stress", "*.ply")),
    Fuzzed("pbrt scene", "scene.pbrt", load_scene,
           seeds(DATA, "*.pbrt") + seeds(DATA / "fuzz", "*.pbrt"),
           siblings=seeds(DATA / "fuzz", "*")),
    Fuzzed("PLY mesh", "mesh.ply", load_scene,
           seeds(SCENES / "stress", "*.ply") + seeds(DATA, "*.ply") + seeds(DATA / "fuzz", "*.ply")),
    Fuzzed("Mitsuba XML scene", "scene.xml", load_scene, seeds(DATA / "fuzz", "*.xml")),
    Fuzzed("plugin manifest", "plugin.toml", load_plugin_folder,
           seeds(REPO / "plugins", "*/plugin.toml"),
           siblings=seeds(REPO / "plugins", "*/*.glsl") + seeds(REPO / "plugins", "*/*.cl")),
]

# Values that break naive parsers: non-finite and huge numbers, wrong types, unbalanced
# brackets and quotes, control and non-UTF-8 bytes, directives and tables out of place.
HOSTILE = [b"nan", b"inf", b"-inf", b"1e999", b"-1e999", b"1e39", b"3.5e38", b"1e308", b"0", b"-0.0",
           b"-1", b"1e-45", b"99999999999999999999", b"4294967296", b"1000000000000", b"0x1p3",
           b'"x"', b'""', b"'", b'"', b"[]", b"[1, 2]", b"[[1]]", b"[[[[[[[[[[[[", b"]]", b"{}",
           b"{ a = 1 }", b"true", b"false", b"=", b"==", b"\n", b"\r\n", b"#", b"\x00", b"\xff\xfe",
           b"\xc3\x28", "\u00e9".encode(), b"\t", b"[[objects]]", b"[materials.x]", b"[camera]",
           b"type = \"mesh\"", b"file = \"/dev/zero\"", b"file = \"..\"", b"AttributeEnd",
           b"Include \"scene.pbrt\"", b"Include \"nowhere.pbrt\"", b"Scale 0 0 0", b"Rotate 1 0 0 0",
           b"element vertex 1000000000000", b"end_header", b"property list uchar int x",
           b"format binary_little_endian 1.0"]
_TOKEN = re.compile(rb'"[^"\n]*"|[-+]?[0-9][0-9eE.+-]*|[A-Za-z_][A-Za-z0-9_.]*|[\[\]{}=]')


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One fuzz input from a seed: truncated, or edited 1-8 times, or replaced by noise."""
    mode = rng.random()
    if mode < 0.25:
        return data[:rng.randrange(len(data) + 1)]
    if mode < 0.3:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(512)))
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        op = rng.random()
        tokens = list(_TOKEN.finditer(out))
        if op < 0.4 and tokens:  # replace a value, name or bracket
            t = rng.choice(tokens)
            out[t.start():t.end()] = rng.choice(HOSTILE)
        elif op < 0.6:  # insert a hostile token or a few random bytes
            at = rng.randrange(len(out) + 1)
            piece = rng.choice(HOSTILE) if rng.random() < 0.7 else bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
            out[at:at] = piece
        elif op < 0.75 and out:  # delete a span
            a = rng.randrange(len(out))
            del out[a:a + rng.randint(1, 32)]
        else:  # duplicate or move a line
            lines = bytes(out).split(b"\n")
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            if rng.random() < 0.5:
                lines.insert(j, lines[i])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            out = bytearray(b"\n".join(lines))
    return bytes(out)


def prepare(loader: Fuzzed, folder: Path) -> Path:
    """A fresh folder with the loader's siblings; returns the path the input goes to."""
    folder.mkdir(parents=True, exist_ok=True)
    for f in loader.siblings:
        target = folder / f.name
        if not target.exists():
            shutil.copy(f, target)
    return folder / loader.filename


def check_input(loader: Fuzzed, data: bytes, path: Path) -> str:
    """Run the property on one input: 'loaded', 'refused' (with file:line) or 'refused, no
    line' (the error names the file only), or raise what escaped."""
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scene warnings name file:line; not the point here
        try:
            result = loader.load(path)
        except LiftError as exc:
            message = str(exc)
            assert not exc.internal, f"{loader.name}: a loader failure it did not foresee: {message}"
            assert exc.path, f"{loader.name}: the error names no file: {message}"
            assert "\n" not in message, f"{loader.name}: not one line: {message!r}"
            return "refused" if exc.line is not None else "refused, no line"
        if isinstance(result, Scene):
            packed = pack_scene(result, cache_dir=path.parent / "bvh-cache")
            # (Other arrays hold integer bit patterns in float32, so only these are floats.)
            for name in ("tri_pos", "tri_normal", "materials", "bounds"):
                assert np.isfinite(getattr(packed, name)).all(), f"{loader.name}: non-finite {name}"
    return "loaded"
