"""Hypothesis strategies of fuzz inputs (fuzz_harness.Case), one a loader.

Each format has a builder that draws a valid file from the format's structure (a scene's
tables, a pbrt statement list, an XML element tree, a glTF document and its buffers, mesh
arrays, image pixels), then breaks it on three levels:
- structure: a value replaced by one of another type or by a hostile number (NaN, Inf,
  1e39, -0, 2^64, 1e-320), a key or element deleted, repeated or renamed, a list emptied
  or made huge, nesting made deep (HOSTILE, broken_tree);
- references: a mesh, include, texture, environment map or shader the file names is valid,
  damaged, missing, a link to /dev/zero or /etc/passwd, a folder, a FIFO, a symbolic-link
  loop, outside the file's folder (reference);
- bytes: truncation, a UTF-8 BOM, UTF-16, a Latin-1 byte, CR or CRLF line ends, NUL bytes,
  token edits and random noise (damaged).
Every strategy also mutates the corpus (fuzz_corpus.py: shipped scenes, test data and the
cases of issue 32) byte by byte, as the first fuzzer did (token_mutate).
"""
from __future__ import annotations

import base64
import copy
import functools
import io
import json
import math
import os
import random
import re
import struct
import tempfile
import zlib
from pathlib import Path

import numpy as np
from hypothesis import strategies as st

from fuzz_harness import Case, Fifo, Folder, Link

# ---- hostile values -------------------------------------------------------------------------

NAN, INF = float("nan"), float("inf")
HOSTILE_FLOATS = [NAN, INF, -INF, 1e308, -1e308, 1e39, -1e39, 3.5e38, 3.4028235e38, 1e19, 1e18, 1e10, -1e10,
                  1e-45, 1e-320, 5e-324, -0.0, 0.0, -1.0, -5.0, -100.0, 1e-12, 0.5, 9007199254740993.0, 180.0,
                  360.0, 1e6]
HOSTILE_INTS = [0, -1, 1, -2 ** 31, 2 ** 31 - 1, 2 ** 31, 2 ** 32, 2 ** 63 - 1, -2 ** 63, 2 ** 64, 10 ** 30,
                10 ** 12, 100000, 65536, 16385, 3]
HOSTILE_STRINGS = ["", " ", "x", "\x00", "\x1b[31m", "\u00e9", "\u202e", "\ufeff", "../../../../../../etc/passwd",
                   "/dev/zero", "/etc/passwd", "..", ".", "nan", "inf", "true", "a" * 3000, "\\", '"', "'", "{", "[",
                   "$res", "${x}", "%s%n", "CON", "file:///etc/passwd", "data:,x", "  padded  ", "\n", "1e39"]


class Deep:
    """A list nested `depth` times, written out by the serializers as text (building it as
    Python objects would hit the recursion limit of the serializer, not of the loader)."""

    def __init__(self, depth: int):
        self.depth = depth

    def __repr__(self):
        return f"Deep({self.depth})"


class Huge:
    """A list of `count` copies of `item`."""

    def __init__(self, count: int, item=0):
        self.count, self.item = count, item

    def __repr__(self):
        return f"Huge({self.count}, {self.item!r})"


@functools.lru_cache(maxsize=None)
def _cached_choice(options: tuple):
    return st.sampled_from(options)


def pick(options):
    """st.sampled_from, built once for each list of options: strategies made anew inside
    every draw cost hypothesis more than the drawing (its first example to ~40 ms)."""
    try:
        return _cached_choice(tuple(options))
    except TypeError:  # unhashable options
        return st.sampled_from(options)


@functools.lru_cache(maxsize=None)
def rarely(n: int):
    """True about once in n draws. (Not `integers(0, n - 1) == 0`: hypothesis favours the
    simplest value, 0, and would make the rare case common.)"""
    return st.sampled_from([False] * (n - 1) + [True])


@functools.lru_cache(maxsize=None)
def ints(lo: int, hi: int):
    return st.integers(lo, hi)


hostile_floats = pick(HOSTILE_FLOATS)
hostile_ints = pick(HOSTILE_INTS)
hostile_numbers = st.one_of(hostile_floats, hostile_ints)
hostile_strings = st.one_of(pick(HOSTILE_STRINGS), st.text(max_size=6))
hostile_scalars = st.one_of(hostile_floats, hostile_ints, st.booleans(), hostile_strings)
HOSTILE = st.one_of(
    hostile_scalars,
    st.lists(hostile_scalars, max_size=5),
    st.lists(hostile_floats, min_size=3, max_size=3),
    st.lists(st.lists(hostile_numbers, max_size=4), max_size=3),
    st.builds(Deep, pick([30, 200, 2000, 20000])),
    st.builds(Huge, pick([1000, 100000]), pick([0, 1.5, "x", [0, 0, 0]])),
    st.dictionaries(pick(["a", "type", "x", ""]), hostile_scalars, max_size=2),
)


def _spots(doc, path=()):
    """Every (container, key) of a tree of dicts and lists."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield doc, k
            yield from _spots(v)
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield doc, i
            yield from _spots(v)


UNKNOWN_KEYS = ["typo", "colour", "Type", "file ", "", "é", "__proto__", "size", "type", "emission", "radius"]


# Structural edits an input gets: none in a third of them, so that valid files are common.
EDIT_COUNTS = pick([0, 0, 0, 1, 1, 2, 3, 4])


@st.composite
def broken_tree(draw, doc):
    """`doc` (dicts and lists) with 0 to 4 structural edits, and their description."""
    doc = copy.deepcopy(doc)
    done = []
    for _ in range(draw(EDIT_COUNTS)):
        spots = list(_spots(doc))
        op = draw(pick(["replace", "replace", "number", "number", "delete", "add", "repeat",
                                   "wrap", "empty", "retype"]))
        if op == "add" or not spots:
            containers = [doc] + [c[k] for c, k in spots if isinstance(c[k], dict)]
            target = draw(pick(containers))
            key = draw(pick(UNKNOWN_KEYS))
            target[key] = draw(HOSTILE)
            done.append(f"add {key!r}")
            continue
        parent, key = draw(pick(spots))
        value = parent[key]
        if op == "replace":
            parent[key] = draw(HOSTILE)
        elif op == "number":
            parent[key] = draw(hostile_numbers)
        elif op == "delete":
            del parent[key]
        elif op == "repeat":
            if isinstance(parent, list):
                parent.insert(key, copy.deepcopy(value))
            elif isinstance(value, list) and value:
                parent[key] = value * draw(pick([2, 50, 3000]))
            else:
                parent[key] = [value, value]
        elif op == "wrap":
            parent[key] = [value] if not isinstance(value, list) else {"0": value}
        elif op == "empty":
            parent[key] = {} if isinstance(value, dict) else [] if isinstance(value, list) else ""
        else:  # retype: a number as a string, a string as a number, ...
            parent[key] = (str(value) if isinstance(value, (int, float)) else
                           1.0 if isinstance(value, str) else draw(hostile_scalars))
        done.append(f"{op} {key!r}")
    return doc, done


# ---- bytes ----------------------------------------------------------------------------------

TOKEN_HOSTILE = [b"nan", b"inf", b"-inf", b"1e999", b"-1e999", b"1e39", b"3.5e38", b"1e308", b"0", b"-0.0",
                 b"-1", b"1e-45", b"99999999999999999999", b"4294967296", b"1000000000000", b"0x1p3",
                 b'"x"', b'""', b"'", b'"', b"[]", b"[1, 2]", b"[[1]]", b"[[[[[[[[[[[[", b"]]", b"{}",
                 b"{ a = 1 }", b"true", b"false", b"=", b"==", b"\n", b"\r\n", b"#", b"\x00", b"\xff\xfe",
                 b"\xc3\x28", "\u00e9".encode(), b"\t", b"[[objects]]", b"[materials.x]", b"[camera]",
                 b"type = \"mesh\"", b"file = \"/dev/zero\"", b"file = \"..\"", b"AttributeEnd",
                 b"Include \"scene.pbrt\"", b"Include \"nowhere.pbrt\"", b"Scale 0 0 0", b"Rotate 1 0 0 0",
                 b"element vertex 1000000000000", b"end_header", b"property list uchar int x",
                 b"format binary_little_endian 1.0", b"<include filename=\"scene.xml\"/>", b"<ref id=\"x\"/>",
                 b"</scene>", b"<!--", b"&amp;", b"&x;", b"$res", b"f 1 2 0", b"f -9 1 2", b"v nan 0 0",
                 b"mtllib /dev/zero", b"\"NaN\"", b"NaN", b"Infinity", b"null", b"{\"a\":", b"\"uri\": \"..\""]
_TOKEN = re.compile(rb'"[^"\n]*"|[-+]?[0-9][0-9eE.+-]*|[A-Za-z_][A-Za-z0-9_.]*|[\[\]{}=<>]')


def token_mutate(data: bytes, rng: random.Random) -> bytes:
    """One input from a seed: truncated, or edited 1-8 times (values, names and brackets
    replaced by hostile tokens, bytes inserted and deleted, lines repeated or moved), or
    replaced by noise."""
    mode = rng.random()
    if mode < 0.2:
        return data[:rng.randrange(len(data) + 1)]
    if mode < 0.25:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(512)))
    out = bytearray(data)
    for _ in range(rng.randint(1, 8)):
        op = rng.random()
        tokens = list(_TOKEN.finditer(out)) if len(out) < 200_000 else []
        if op < 0.4 and tokens:
            t = rng.choice(tokens)
            out[t.start():t.end()] = rng.choice(TOKEN_HOSTILE)
        elif op < 0.6:
            at = rng.randrange(len(out) + 1)
            piece = (rng.choice(TOKEN_HOSTILE) if rng.random() < 0.7
                     else bytes(rng.randrange(256) for _ in range(rng.randint(1, 8))))
            out[at:at] = piece
        elif op < 0.75 and out:
            a = rng.randrange(len(out))
            del out[a:a + rng.randint(1, 32)]
        elif op < 0.85 and out:  # flip bytes (binary formats)
            for _ in range(rng.randint(1, 4)):
                out[rng.randrange(len(out))] = rng.randrange(256)
        else:
            lines = bytes(out).split(b"\n")
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            if rng.random() < 0.5:
                lines.insert(j, lines[i])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            out = bytearray(b"\n".join(lines))
    return bytes(out)


TEXT_DAMAGE = ["none"] * 10 + ["bom", "utf16", "latin1", "crlf", "cr", "truncate", "nul", "tokens", "tokens",
                               "noise", "lines"]


@st.composite
def damaged(draw, text: str, comment: str = "#"):
    """The text's UTF-8 bytes, perhaps damaged; and what was done."""
    data = text.encode("utf-8", "surrogatepass")
    op = draw(pick(TEXT_DAMAGE))
    if op == "none":
        return data, None
    if op == "bom":
        return b"\xef\xbb\xbf" + data, op
    if op == "utf16":
        return text.encode("utf-16", "surrogatepass"), op
    if op == "latin1":
        lines = text.split("\n")
        at = draw(st.integers(0, len(lines)))
        lines.insert(at, f"{comment} caf\u00e9, na\u00efve")
        return "\n".join(lines).encode("latin-1", "replace"), op
    if op == "crlf":
        return data.replace(b"\n", b"\r\n"), op
    if op == "cr":
        return data.replace(b"\n", b"\r"), op
    if op == "nul":
        at = draw(st.integers(0, len(data)))
        return data[:at] + b"\x00" + data[at:], op
    if op == "lines":
        lines = data.split(b"\n")
        i, j = draw(st.integers(0, len(lines) - 1)), draw(st.integers(0, len(lines) - 1))
        lines.insert(j, lines[i])
        return b"\n".join(lines), op
    return draw(damaged_bytes(data, op))


@st.composite
def damaged_bytes(draw, data: bytes, op: str | None = None):
    """Bytes perhaps truncated, edited by tokens, flipped or replaced by noise."""
    op = op or draw(pick(["none"] * 6 + ["truncate", "tokens", "tokens", "noise", "flip"]))
    if op == "none":
        return data, None
    if op == "truncate":
        return data[:draw(st.integers(0, max(len(data) - 1, 0)))], op
    if op == "noise":
        return draw(st.binary(max_size=300)), op
    if op == "flip":
        out = bytearray(data)
        for _ in range(draw(st.integers(1, 4))):
            if out:
                out[draw(st.integers(0, len(out) - 1))] = draw(st.integers(0, 255))
        return bytes(out), op
    return token_mutate(data, draw(st.randoms(use_true_random=False))), "tokens"


def _how(*parts) -> str:
    return "; ".join(str(p) for p in parts if p)


# ---- references to other files --------------------------------------------------------------

REFERENCE_KINDS = (["valid"] * 12 + ["damaged", "damaged", "missing", "devzero", "devnull", "passwd", "folder",
                                      "fifo", "loop", "selflink", "dangling", "absolute", "outside", "outside-link",
                                      "empty", "unicode", "nul", "proc"])


@st.composite
def reference(draw, stem: str, content):
    """A file another file names: (the name as written, {file name: content}, what it is).
    `content`: a strategy of (extension, bytes)."""
    kind = draw(pick(REFERENCE_KINDS))
    ext, data = draw(content)
    name = stem + ext
    if kind == "valid":
        return name, {name: data}, None
    if kind == "damaged":
        broken, op = draw(damaged_bytes(data))
        return name, {name: broken}, f"{name} {op}"
    if kind == "missing":
        return name, {}, f"{name} missing"
    if kind == "devzero":
        return name, {name: Link("/dev/zero")}, f"{name} -> /dev/zero"
    if kind == "devnull":
        return name, {name: Link("/dev/null")}, f"{name} -> /dev/null"
    if kind == "passwd":
        return "../" * 24 + "etc/passwd", {}, "../../etc/passwd"
    if kind == "folder":
        return name, {name: Folder()}, f"{name} is a folder"
    if kind == "fifo":
        return name, {name: Fifo()}, f"{name} is a FIFO"
    if kind == "loop":
        return name, {name: Link("loop-b" + ext), "loop-b" + ext: Link(name)}, f"{name} symlink loop"
    if kind == "selflink":
        return name, {name: Link(name)}, f"{name} links to itself"
    if kind == "dangling":
        return name, {name: Link("nowhere" + ext)}, f"{name} dangling link"
    if kind == "absolute":
        return "/dev/zero", {}, "/dev/zero"
    if kind == "outside":
        return "../" + name, {"../" + name: data}, f"../{name}"
    if kind == "outside-link":
        return name, {name: Link("../real" + ext), "../real" + ext: data}, f"{name} -> ../real{ext}"
    if kind == "empty":
        return "", {}, "empty name"
    if kind == "unicode":
        return f"caf\u00e9 {stem}{ext}", {f"caf\u00e9 {stem}{ext}": data}, None
    if kind == "proc":
        return "/proc/self/status", {}, "/proc/self/status"
    return stem + "\x00" + ext, {}, "NUL in the name"


# ---- images ---------------------------------------------------------------------------------

_png_modes = pick(["L", "LA", "RGB", "RGBA", "P", "1", "I;16"])


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


@st.composite
def png_bytes(draw, width=None, height=None):
    from PIL import Image

    w = width or draw(st.integers(1, 9))
    h = height or draw(st.integers(1, 9))
    mode = draw(_png_modes)
    seed = draw(st.integers(0, 2 ** 16))
    rng = np.random.default_rng(seed)
    if mode == "I;16":
        img = Image.fromarray(rng.integers(0, 65535, (h, w)).astype(np.uint16))
    else:
        img = Image.fromarray(rng.integers(0, 255, (h, w, 4)).astype(np.uint8), "RGBA").convert(mode)
    out = io.BytesIO()
    img.save(out, "PNG")
    data = out.getvalue()
    claim = draw(pick([None] * 8 + [(0, 0), (1 << 14, 1 << 14), (12000, 12000), (100000, 1),
                                               (1, 100000), (65535, 65535), (2 ** 31 - 1, 1), (2 ** 32 - 1, 2)]))
    if claim is not None:  # a header claiming a size its data does not hold (a decompression bomb)
        ihdr = bytearray(data[16:29])
        ihdr[0:8] = struct.pack(">II", *claim)
        data = data[:8] + _chunk(b"IHDR", bytes(ihdr)) + data[33:]
    return ".png", data


@st.composite
def pil_bytes(draw, fmt: str):
    from PIL import Image

    w, h = draw(st.integers(1, 9)), draw(st.integers(1, 9))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 16)))
    img = Image.fromarray(rng.integers(0, 255, (h, w, 3)).astype(np.uint8), "RGB")
    if fmt == "GIF" or draw(st.booleans()):
        img = img.convert(draw(pick(["L", "P", "RGB"])) if fmt != "JPEG" else "L")
    out = io.BytesIO()
    img.save(out, fmt)
    return {"JPEG": ".jpg", "BMP": ".bmp", "TGA": ".tga", "GIF": ".gif", "TIFF": ".tif"}[fmt], out.getvalue()


@st.composite
def float_pixels(draw, width=None, height=None, channels=3):
    """A small float image with, often, hostile texels (NaN, Inf, negative, huge)."""
    w = width or draw(st.integers(1, 9))
    h = height or draw(st.integers(1, 9))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 16)))
    px = rng.uniform(0, draw(pick([1.0, 4.0, 100.0])), (h, w, channels)).astype(np.float32)
    for _ in range(draw(pick([0, 0, 0, 1, 2, 5]))):
        px[draw(st.integers(0, h - 1)), draw(st.integers(0, w - 1)), draw(st.integers(0, channels - 1))] = \
            draw(pick([NAN, INF, -INF, -100.0, -1e-3, 3e38, 65504.0, 1e-40]))
    if draw(rarely(21)):
        px[:] = draw(pick([NAN, 0.0, -1.0, INF]))
    return px


_SCRATCH = Path(tempfile.mkdtemp(prefix="lift-gl-fuzz-images-"))


@st.composite
def exr_bytes(draw, width=None, height=None):
    import OpenEXR

    px = draw(float_pixels(width, height, channels=4))
    layout = draw(pick(["RGB", "RGB", "RGBA", "Y", "RG", "Z", "layer"]))
    dtype = draw(pick([np.float32, np.float32, np.float16, np.uint32]))
    with np.errstate(all="ignore"):
        px = px.astype(dtype) if dtype is not np.uint32 else np.nan_to_num(px).clip(0, 1e9).astype(np.uint32)
    channels = {"RGB": {"RGB": px[..., :3]}, "RGBA": {"RGBA": px}, "Y": {"Y": px[..., 0]},
                "RG": {"R": px[..., 0], "G": px[..., 1]}, "Z": {"Z": px[..., 0]},
                "layer": {"diffuse.R": px[..., 0], "diffuse.G": px[..., 1], "diffuse.B": px[..., 2]}}[layout]
    compression = draw(pick([OpenEXR.ZIP_COMPRESSION, OpenEXR.NO_COMPRESSION, OpenEXR.PIZ_COMPRESSION,
                                        OpenEXR.RLE_COMPRESSION]))
    path = _SCRATCH / f"{os.getpid()}.exr"
    with OpenEXR.File({"compression": compression, "type": OpenEXR.scanlineimage},
                      {k: np.ascontiguousarray(v) for k, v in channels.items()}) as f:
        f.write(str(path))
    data = path.read_bytes()
    window = draw(pick([None] * 6 + [(0, 0, -1, -1), (0, 0, 1 << 14, 1 << 14), (0, 0, 1 << 20, 0),
                                                (-2 ** 31, 0, 2 ** 31 - 1, 0), (5, 5, 2, 2)]))
    at = data.find(b"dataWindow\x00box2i\x00")
    if window is not None and at >= 0:
        j = at + len(b"dataWindow\x00box2i\x00") + 4
        data = data[:j] + struct.pack("<4i", *window) + data[j + 16:]
    return ".exr", data


@st.composite
def pfm_bytes(draw, width=None, height=None):
    grey = draw(rarely(5))
    px = draw(float_pixels(width, height, channels=1 if grey else 3))
    h, w = px.shape[:2]
    little = draw(st.booleans())
    magic = draw(pick(["Pf" if grey else "PF"] * 8 + ["PF", "Pf", "P6", "pf", ""]))
    size = draw(pick([f"{w} {h}"] * 8 + [f"{w}", "0 0", f"-{w} {h}", "100000 100000", "4.0 2",
                                                     f"{w}\n{h}", "x y", f"{2 ** 40} 1"]))
    scale = draw(pick(["-1.0" if little else "1.0"] * 8 + ["0", "nan", "-inf", "x", "-1e-45"]))
    body = px[::-1].astype("<f4" if little else ">f4").tobytes()
    body = draw(pick([body] * 6 + [body[:len(body) // 2], body + b"\x00" * 16, b""]))
    return ".pfm", f"{magic}\n{size}\n{scale}\n".encode() + body


def _rgbe(px: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        v = np.nan_to_num(px.max(axis=2), nan=0.0, posinf=1e30, neginf=0.0)
        mant, exp = np.frexp(v)
        scale = np.where(v > 1e-32, mant * 256.0 / np.where(v > 0, v, 1), 0)
        rgb = np.clip(np.nan_to_num(px) * scale[..., None], 0, 255).astype(np.uint8)
        e = np.where(v > 1e-32, np.clip(exp + 128, 0, 255), 0).astype(np.uint8)
    return np.concatenate([rgb, e[..., None]], axis=2)


@st.composite
def hdr_bytes(draw, width=None, height=None):
    px = draw(float_pixels(width, height))
    h, w = px.shape[:2]
    rgbe = _rgbe(px)
    fmt = draw(pick(["FORMAT=32-bit_rle_rgbe\n"] * 6 + ["", "FORMAT=32-bit_rle_xyze\n"]))
    resolution = draw(pick([f"-Y {h} +X {w}"] * 6 + [f"+Y {h} -X {w}", f"-Y 100000 +X 100000",
                                                                 f"-Y 0 +X {w}", f"+X {w} -Y {h}", "-Y x +X y",
                                                                 f"-Y {h * 1000} +X {w}"]))
    rle = w >= 8 and draw(st.booleans())
    body = bytearray()
    for row in rgbe:
        if rle:
            body += bytes([2, 2, w >> 8, w & 255])
            for c in range(4):
                x = 0
                while x < w:
                    n = min(w - x, 127)
                    body += bytes([n]) + row[x:x + n, c].tobytes()
                    x += n
        else:
            body += row.tobytes()
    if rle and draw(rarely(4)):  # a corrupt run
        body[4 + draw(st.integers(0, 3))] = draw(pick([0, 128, 255]))
    magic = draw(pick(["#?RADIANCE"] * 6 + ["#?RGBE", "#?", ""]))
    return ".hdr", f"{magic}\n{fmt}\n{resolution}\n".encode() + bytes(body)


@st.composite
def npy_bytes(draw, width=None, height=None):
    px = draw(float_pixels(width, height, channels=4))
    shape = draw(pick(["hw3"] * 4 + ["hw", "hw4", "hw1", "0w3", "hw31", "flat", "scalar"]))
    h, w = px.shape[:2]
    arr = {"hw3": px[..., :3], "hw": px[..., 0], "hw4": px, "hw1": px[..., :1], "0w3": px[:0, :, :3],
           "hw31": px[..., :3, None], "flat": px.reshape(-1), "scalar": np.float32(1.0)}[shape]
    dtype = draw(pick([np.float32, np.float32, np.float64, np.float16, np.int64, np.bool_,
                                  np.complex64, object]))
    with np.errstate(all="ignore"):
        arr = np.asarray(arr).astype(dtype)
    out = io.BytesIO()
    np.save(out, np.asfortranarray(arr) if draw(st.booleans()) else arr, allow_pickle=True)
    data = out.getvalue()
    claim = draw(pick([None] * 6 + ["(100000, 100000, 3)", "(-1, 3, 3)", "(8, 8, 3)", "()"]))
    if claim is not None:
        data = re.sub(rb"'shape': \([^)]*\)", f"'shape': {claim}".encode(), data, count=1)
    return ".npy", data


@functools.lru_cache(maxsize=None)
def image_content(kinds: tuple):
    makers = {"png": png_bytes(), "jpg": pil_bytes("JPEG"), "bmp": pil_bytes("BMP"), "tga": pil_bytes("TGA"),
              "gif": pil_bytes("GIF"), "tif": pil_bytes("TIFF"), "exr": exr_bytes(), "pfm": pfm_bytes(),
              "hdr": hdr_bytes(), "npy": npy_bytes()}
    return st.one_of(*(makers[k] for k in kinds))


TEXTURE_IMAGES = ("png", "png", "png", "jpg", "bmp", "tga", "gif", "tif", "exr", "pfm", "hdr")
ENVIRONMENT_IMAGES = ("exr", "exr", "pfm", "pfm", "hdr", "hdr", "png", "jpg")

# ---- meshes ---------------------------------------------------------------------------------

coords = st.floats(-4, 4, allow_nan=False, width=32)


@st.composite
def mesh_arrays(draw):
    """(positions (n, 3), faces (polygons as index lists), normals or None, uvs or None),
    valid or with a few hostile values and indices. The arrays come from a generator seeded
    by one draw (drawing each number through hypothesis costs ~0.1 ms apiece)."""
    rng = np.random.default_rng(draw(ints(0, 2 ** 32 - 1)))
    n = draw(ints(3, 10))
    positions = np.round(rng.uniform(-4, 4, (n, 3)), draw(pick([1, 3, 7])))
    polygon = draw(pick([3, 3, 4, 6]))
    faces = [list(rng.integers(0, n, rng.integers(3, polygon + 1))) for _ in range(draw(ints(1, 12)))]
    faces = [[int(i) for i in f] for f in faces]
    normals = rng.normal(size=(n, 3)) if draw(st.booleans()) else None
    uvs = rng.uniform(0, 1, (n, 2)) if draw(st.booleans()) else None
    for _ in range(draw(pick([0] * 6 + [1, 3]))):
        positions[rng.integers(n), rng.integers(3)] = draw(hostile_floats)
    for _ in range(draw(pick([0] * 8 + [1, 2]))):
        face = faces[rng.integers(len(faces))]
        face[rng.integers(len(face))] = draw(pick([n, -1, -n - 1, 2 ** 31 - 1, 2 ** 32, 0]))
    if draw(rarely(13)):
        faces.append(list(range(n)) * draw(pick([1, 100])))  # a huge polygon
    return positions, faces, normals, uvs


def _num(v) -> str:
    return repr(float(v)) if isinstance(v, float) or isinstance(v, np.floating) else str(v)


@st.composite
def ply_text(draw):
    """A PLY file (ASCII or binary) and what was broken."""
    positions, faces, normals, uvs = draw(mesh_arrays())
    fmt = draw(pick(["ascii", "binary_little_endian", "binary_big_endian"]))
    end = "<" if fmt == "binary_little_endian" else ">"
    uv_names = draw(pick([("u", "v"), ("s", "t"), ("texture_u", "texture_v")]))
    count_type, index_type = draw(pick([("uchar", "int"), ("uchar", "uint"), ("ushort", "int"),
                                                   ("int", "int"), ("uint8", "uint32"), ("char", "short")]))
    props = [("float", "x"), ("float", "y"), ("float", "z")]
    if normals is not None:
        props += [("float", "nx"), ("float", "ny"), ("float", "nz")]
    if uvs is not None:
        props += [("float", uv_names[0]), ("float", uv_names[1])]
    n, f = len(positions), len(faces)
    claims = {"vertex": n, "face": f}
    broken = draw(pick([None] * 10 + ["count+", "count-", "huge", "type", "noend", "order", "extra",
                                                 "listtype", "comment", "negative"]))
    if broken == "count+":
        claims["vertex"] += draw(st.integers(1, 5))
    elif broken == "count-":
        claims["face"] = max(0, f - draw(st.integers(1, 3)))
    elif broken == "huge":
        claims[draw(pick(["vertex", "face"]))] = draw(pick([2 ** 31, 10 ** 12, 2 ** 28 + 1,
                                                                                  50_000_000]))
    header = ["ply", f"format {fmt} 1.0"]
    if broken == "comment":
        header.append("comment caf\u00e9 \x00 \xff")
    vertex = [f"element vertex {claims['vertex']}"] + [f"property {t} {name}" for t, name in props]
    face_type = count_type if broken != "listtype" else draw(pick(["float", "double", "list"]))
    face = [f"element face {claims['face']}", f"property list {face_type} {index_type} vertex_indices"]
    if broken == "type":
        vertex[1] = draw(pick(["property float128 x", "property x", "property list float x",
                                          "property int"]))
    elements = [vertex, face] if broken != "order" else [face, vertex]
    for e in elements:
        header += e
    if broken == "extra":
        header += ["element edge 1", "property int vertex1", "property int vertex2"]
    if broken != "noend":
        header.append("end_header")
    head = ("\n".join(header) + "\n").encode("latin-1", "replace")
    rows = np.concatenate([positions] + ([normals] if normals is not None else [])
                          + ([uvs] if uvs is not None else []), axis=1)
    if fmt == "ascii":
        body = "".join(" ".join(_num(v) for v in row) + "\n" for row in rows)
        body += "".join(f"{len(face) if broken != 'negative' else -1} " + " ".join(map(str, face)) + "\n"
                        for face in faces)
        if broken == "extra":
            body += "0 1\n"
        return head + body.encode(), broken
    ctype = {"uchar": "B", "uint8": "B", "char": "b", "ushort": "H", "int": "i"}[count_type]
    itype = {"int": "i", "uint": "I", "uint32": "I", "short": "h"}[index_type]
    with np.errstate(all="ignore"):
        body = rows.astype(end + "f4").tobytes()
    for face in faces:
        count = len(face) if broken != "negative" else -1
        try:
            body += struct.pack(end + ctype, count) + b"".join(struct.pack(end + itype, i) for i in face)
        except struct.error:  # an index or a count its type cannot hold: bytes that say as much
            limit = {"B": 255, "b": 127, "H": 65535, "i": 2 ** 31 - 1}[ctype]
            body += struct.pack(end + ctype, min(len(face), limit)) + b"\xff" * 4 * len(face)
    return head + body, broken


@st.composite
def ply_content(draw):
    data, _ = draw(ply_text())
    return ".ply", data


@st.composite
def obj_text(draw, mtl_name=None):
    positions, faces, normals, uvs = draw(mesh_arrays())
    style = draw(pick(["v", "v/vt", "v//vn", "v/vt/vn", "negative"]))
    lines = ["# fuzz OBJ", "o thing"]
    if mtl_name is not None:
        lines += [f"mtllib {mtl_name}", "usemtl skin"]
    for p in positions:
        lines.append("v " + " ".join(_num(v) for v in p) + (" 1.0" if draw(rarely(9)) else ""))
    for t in (uvs if uvs is not None else []):
        lines.append("vt " + " ".join(_num(v) for v in t))
    for nrm in (normals if normals is not None else []):
        lines.append("vn " + " ".join(_num(v) for v in nrm))
    n = len(positions)
    for face in faces:
        corners = []
        for i in face:
            k = i + 1 if style != "negative" else i - n
            if style == "v/vt" and uvs is not None:
                corners.append(f"{k}/{k}")
            elif style == "v//vn" and normals is not None:
                corners.append(f"{k}//{k}")
            elif style == "v/vt/vn" and uvs is not None and normals is not None:
                corners.append(f"{k}/{k}/{k}")
            else:
                corners.append(str(k))
        lines.append(("l " if draw(rarely(30)) else "f ") + " ".join(corners))
    extra = draw(pick([None] * 8 + ["s 1", "g", "f", "f 1", "v", "vt 0", "vn 0 0", "f 0 1 2",
                                               "f 1/2/3/4 2 3", "v 1 2 \\", "mtllib", "usemtl", "v 0x10 0 0",
                                               "f " + " ".join(["1"] * 5000)]))
    if extra:
        lines.insert(draw(st.integers(2, len(lines))), extra)
    return "\n".join(lines) + "\n"


def _mtl_text(texture_name: str) -> str:
    return f"newmtl skin\nKd 0.8 0.5 0.3\nKs 0.1 0.1 0.1\nNs 20\nmap_Kd {texture_name}\n"


@st.composite
def obj_content(draw):
    return ".obj", draw(obj_text()).encode()


# ---- glTF -----------------------------------------------------------------------------------

@st.composite
def gltf_parts(draw, binary: bool):
    """A glTF document, its binary buffer and the files it names (images, .bin)."""
    positions, faces, normals, uvs = draw(mesh_arrays())
    tris = [f[:3] for f in faces]
    index_type = draw(pick([5125, 5123, 5121, None]))  # uint32, uint16, uint8, none
    blob = bytearray()
    views, accessors = [], []

    def add(array: np.ndarray, component: int, kind: str, target=None, minmax=False):
        while len(blob) % 4:
            blob.append(0)
        data = array.tobytes()
        view = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
        if target:
            view["target"] = target
        views.append(view)
        blob.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": component, "count": len(array), "type": kind}
        if minmax:
            with np.errstate(all="ignore"):
                acc["min"] = [float(v) for v in np.nanmin(array, axis=0)]
                acc["max"] = [float(v) for v in np.nanmax(array, axis=0)]
        accessors.append(acc)
        return len(accessors) - 1

    with np.errstate(all="ignore"):  # hostile values beyond float32 become infinities
        attributes = {"POSITION": add(positions.astype("<f4"), 5126, "VEC3", 34962, minmax=True)}
        if normals is not None:
            attributes["NORMAL"] = add(normals.astype("<f4"), 5126, "VEC3", 34962)
        if uvs is not None:
            attributes["TEXCOORD_0"] = add(uvs.astype("<f4"), 5126, "VEC2", 34962)
    primitive = {"attributes": attributes, "mode": draw(pick([4] * 10 + [0, 1, 5, 6, 7]))}
    if index_type is not None:
        dtype = {5125: "<u4", 5123: "<u2", 5121: "u1"}[index_type]
        flat = np.array([i for t in tris for i in t], np.int64)
        with np.errstate(all="ignore"):
            primitive["indices"] = add(flat.astype(dtype), index_type, "SCALAR", 34963)
    files = {}
    images = []
    texture = None
    if draw(rarely(3)):
        name, image_files, _ = draw(reference("tex", png_bytes()))
        if binary and draw(st.booleans()) and name in image_files and isinstance(image_files[name], bytes):
            while len(blob) % 4:
                blob.append(0)
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(image_files[name])})
            blob.extend(image_files[name])
            images.append({"bufferView": len(views) - 1, "mimeType": "image/png"})
        else:
            files.update(image_files)
            images.append({"uri": name})
        texture = {"index": 0}
    material = {"name": "skin", "pbrMetallicRoughness": {
        "baseColorFactor": [draw(st.floats(0, 1)) for _ in range(3)] + [1.0],
        "metallicFactor": draw(pick([0.0, 1.0, 0.5])),
        "roughnessFactor": draw(st.floats(0, 1))}}
    if texture:
        material["pbrMetallicRoughness"]["baseColorTexture"] = texture
    extensions_used = []
    if draw(st.booleans()):
        material["emissiveFactor"] = [draw(st.floats(0, 1)) for _ in range(3)]
        material["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": draw(st.floats(0, 20))}}
        extensions_used.append("KHR_materials_emissive_strength")
    if draw(rarely(4)):
        material.setdefault("extensions", {})["KHR_materials_transmission"] = {"transmissionFactor": 1.0}
        material["extensions"]["KHR_materials_ior"] = {"ior": draw(st.floats(1.0, 2.5))}
        extensions_used += ["KHR_materials_transmission", "KHR_materials_ior"]
    primitive["material"] = 0
    node = {"mesh": 0, "name": "thing"}
    if draw(st.booleans()):
        node["matrix"] = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, draw(coords), draw(coords), draw(coords), 1.0]
    else:
        node.update({"translation": [draw(coords) for _ in range(3)], "rotation": [0, 0, 0, 1],
                     "scale": [draw(st.floats(0.1, 3)) for _ in range(3)]})
    nodes = [node]
    doc = {"asset": {"version": "2.0", "generator": "lift-gl fuzz"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": nodes, "meshes": [{"name": "thing", "primitives": [primitive]}], "materials": [material],
           "accessors": accessors, "bufferViews": views}
    if images:
        doc.update({"images": images, "textures": [{"source": 0, "sampler": 0}], "samplers": [{}]})
    if draw(st.booleans()):
        doc["cameras"] = [{"type": "perspective", "perspective": {
            "yfov": draw(st.floats(0.1, 2.5)), "znear": 0.01, "aspectRatio": draw(st.floats(0.5, 2))}}]
        nodes.append({"camera": 0, "translation": [0.0, 0.5, 6.0]})
        doc["scenes"][0]["nodes"].append(len(nodes) - 1)
    if draw(st.booleans()):
        lights = [{"type": draw(pick(["directional", "directional", "point", "spot"])),
                   "color": [1.0, 0.9, 0.8], "intensity": draw(st.floats(0, 10)), "name": "sun"}]
        if lights[0]["type"] == "spot":
            lights[0]["spot"] = {"innerConeAngle": 0.2, "outerConeAngle": 0.5}
        doc["extensions"] = {"KHR_lights_punctual": {"lights": lights}}
        nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-0.38, 0, 0, 0.92]})
        doc["scenes"][0]["nodes"].append(len(nodes) - 1)
        extensions_used.append("KHR_lights_punctual")
    if draw(rarely(5)):  # a hierarchy
        nodes.append({"children": [0], "scale": [2.0, 2.0, 2.0]})
        doc["scenes"][0]["nodes"] = [len(nodes) - 1] + doc["scenes"][0]["nodes"][1:]
    if extensions_used:
        doc["extensionsUsed"] = extensions_used
    buffer = {"byteLength": len(blob)}
    if not binary:
        if draw(st.booleans()):
            buffer["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()
        else:
            bin_name, bin_files, _ = draw(reference("scene", st.just((".bin", bytes(blob)))))
            buffer["uri"] = bin_name
            files.update(bin_files)
    doc["buffers"] = [buffer]
    return doc, bytes(blob), files


def _json_default(o):
    if isinstance(o, Huge):
        return [o.item] * o.count
    raise TypeError(type(o))


def _json_with_deep(doc) -> str:
    """JSON of `doc`, Deep values spelled out to their full depth."""
    marks = {}

    def swap(o):
        if isinstance(o, Deep):
            key = f"@@deep{len(marks)}@@"
            marks[key] = "[" * o.depth + "]" * o.depth
            return key
        if isinstance(o, dict):
            return {k: swap(v) for k, v in o.items()}
        if isinstance(o, list):
            return [swap(v) for v in o]
        return o

    text = json.dumps(swap(doc), default=_json_default)
    for key, value in marks.items():
        text = text.replace(f'"{key}"', value)
    return text


def glb_pack(json_text: str, blob: bytes, broken=None) -> bytes:
    j = json_text.encode("utf-8", "surrogatepass")
    j += b" " * (-len(j) % 4)
    b = blob + b"\x00" * (-len(blob) % 4)
    chunks = struct.pack("<I", len(j)) + b"JSON" + j
    if blob or broken == "bin":
        chunks += struct.pack("<I", len(b)) + b"BIN\x00" + b
    length = 12 + len(chunks)
    version = 2
    if broken == "length":
        length = 0xFFFFFFFF
    if broken == "version":
        version = 1
    if broken == "jsonlength":
        chunks = struct.pack("<I", 0x7FFFFFFF) + chunks[4:]
    if broken == "chunktype":
        chunks = chunks[:4] + b"BIN\x00" + chunks[8:]
    if broken == "extra":
        chunks += struct.pack("<I", 4) + b"XTRA" + b"abcd"
    return b"glTF" + struct.pack("<II", version, length) + chunks


TOP_LEVEL_NOT_OBJECT = ["[]", "[{}]", "\"scene\"", "0", "null", "true", "{}", "{\"asset\": {}}"]


@st.composite
def gltf_cases(draw, binary: bool):
    if draw(rarely(31)):
        text = draw(pick(TOP_LEVEL_NOT_OBJECT))
        return Case(glb_pack(text, b"") if binary else text.encode(), how=f"top level {text}",
                    name="scene.glb" if binary else "scene.gltf")
    doc, blob, files = draw(gltf_parts(binary))
    doc, edits = draw(broken_tree(doc))
    if blob and draw(rarely(6)):  # hostile floats in the buffer itself
        b = bytearray(blob)
        for _ in range(draw(st.integers(1, 4))):
            at = draw(st.integers(0, max(len(b) // 4 - 1, 0))) * 4
            with np.errstate(all="ignore"):
                b[at:at + 4] = np.float32(draw(hostile_floats)).astype("<f4").tobytes()
        blob = bytes(b[:draw(pick([len(b), len(b), len(b) // 2]))])
        edits.append("buffer values")
    text = _json_with_deep(doc)
    if binary:
        broken = draw(pick([None] * 12 + ["length", "version", "jsonlength", "chunktype", "extra", "bin"]))
        data, op = draw(damaged_bytes(glb_pack(text, blob, broken)))
        return Case(data, files, _how("glb", edits, broken, op), name="scene.glb")
    data, op = draw(damaged(text))
    return Case(data, files, _how("gltf", edits, op), name="scene.gltf")


# ---- TOML -----------------------------------------------------------------------------------

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_key(k) -> str:
    k = str(k)
    return k if _BARE.match(k) else toml_string(k)


def toml_string(s: str) -> str:
    out = ['"']
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        elif 0xD800 <= ord(ch) <= 0xDFFF:
            out.append("\\ufffd")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = repr(v)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(v, str):
        return toml_string(v)
    if isinstance(v, Deep):
        return "[" * v.depth + "0" + "]" * v.depth
    if isinstance(v, Huge):
        return "[" + ", ".join([toml_value(v.item)] * v.count) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, np.ndarray):
        return toml_value(v.tolist())
    return toml_string(str(v))


def _table_of_tables(v) -> bool:
    return isinstance(v, dict) and bool(v) and all(isinstance(x, dict) for x in v.values())


def toml_text(doc: dict, tables_of_tables=("materials", "params")) -> str:
    """TOML of a document: scalars first, then [tables], [name.sub] for tables of tables
    (materials, params) and [[arrays of tables]]; anything else inline."""
    lines = []
    for k, v in doc.items():
        if isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            continue
        lines.append(f"{toml_key(k)} = {toml_value(v)}")
    for k, v in doc.items():
        if isinstance(v, dict):
            if k in tables_of_tables and _table_of_tables(v):
                for name, table in v.items():
                    lines += ["", f"[{toml_key(k)}.{toml_key(name)}]"]
                    lines += [f"{toml_key(a)} = {toml_value(b)}" for a, b in table.items()]
            else:
                lines += ["", f"[{toml_key(k)}]"]
                lines += [f"{toml_key(a)} = {toml_value(b)}" for a, b in v.items()]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for table in v:
                lines += ["", f"[[{toml_key(k)}]]"]
                lines += [f"{toml_key(a)} = {toml_value(b)}" for a, b in table.items()]
    return "\n".join(lines) + "\n"


@st.composite
def repeated_key(draw, text: str):
    """The TOML text with one `key = value` line or table header written twice."""
    lines = text.split("\n")
    candidates = [i for i, line in enumerate(lines) if "=" in line or line.startswith("[")]
    if not candidates:
        return text
    i = draw(pick(candidates))
    lines.insert(i + 1, lines[i])
    return "\n".join(lines)


vec = st.lists(coords, min_size=3, max_size=3)
positive = st.floats(0.05, 3.0)
colour = st.one_of(st.lists(st.floats(0, 1), min_size=3, max_size=3), st.floats(0, 1))


@st.composite
def toml_scene_doc(draw, mesh_refs=True):
    """A valid native scene (scenes/README.md) and the files it names."""
    files = {}
    doc: dict = {}
    if not draw(rarely(4)):
        position = draw(vec)
        target = [position[0] + draw(st.floats(0.5, 3)), position[1], position[2] - draw(st.floats(0.5, 3))]
        camera = {"position": position, "target": target}
        if draw(st.booleans()):
            camera["up"] = [0, 1, 0]
        if draw(st.booleans()):
            camera["fov"] = draw(st.floats(5, 120))
        if draw(rarely(4)):
            camera.update({"aperture": draw(st.floats(0, 0.2)), "focus_distance": draw(positive)})
        if draw(rarely(5)):
            camera["shutter"] = [0, draw(st.floats(0.1, 2))]
        doc["camera"] = camera
    if draw(st.booleans()):
        film = {"size": [draw(st.integers(1, 64)), draw(st.integers(1, 64))]}
        if draw(st.booleans()):
            film["filter"] = draw(pick(["box", "triangle", "gaussian"]))
            film["filter_radius"] = draw(st.one_of(positive, st.lists(positive, min_size=2, max_size=2)))
            if film["filter"] == "gaussian":
                film["filter_alpha"] = draw(positive)
        doc["film"] = film
    if draw(st.booleans()):
        doc["integrator"] = {"max_depth": draw(st.integers(0, 20))}
    if draw(st.booleans()):
        env = {"radiance": draw(colour)}
        if draw(rarely(4)):
            name, env_files, _ = draw(reference("sky", image_content(ENVIRONMENT_IMAGES)))
            env["map"] = name
            files.update(env_files)
            if draw(st.booleans()):
                env["rotate"] = [0, draw(st.floats(-180, 180)), 0]
        doc["environment"] = env
    if draw(rarely(3)):
        doc["lights"] = [{"direction": [draw(coords), 1.0, draw(coords)], "irradiance": draw(colour)}
                         for _ in range(draw(st.integers(1, 3)))]
    materials = {}
    for i in range(draw(st.integers(0, 4))):
        kind = draw(pick(["diffuse", "conductor", "dielectric", "plastic"]))
        m = {"type": kind, "color": draw(colour)}
        if draw(rarely(4)):
            m["emission"] = draw(st.one_of(st.lists(st.floats(0, 20), min_size=3, max_size=3), st.floats(0, 20)))
        if kind in ("conductor", "dielectric", "plastic") and draw(st.booleans()):
            m["roughness" if draw(st.booleans()) else "alpha"] = draw(st.floats(0, 1))
        if kind in ("dielectric", "plastic") and draw(st.booleans()):
            m["ior"] = draw(st.floats(1.0, 2.5))
        if kind == "conductor" and draw(st.booleans()):
            m["metal"] = draw(pick(["gold", "silver", "copper", "aluminium", "chrome"]))
        if kind == "plastic" and draw(st.booleans()):
            m["nonlinear"] = draw(st.booleans())
        if kind != "dielectric" and draw(rarely(5)):
            name, tex_files, _ = draw(reference(f"tex{i}", image_content(TEXTURE_IMAGES)))
            m["texture"] = name
            files.update(tex_files)
        materials[f"m{i}"] = m
    if materials:
        doc["materials"] = materials
    objects = []
    names = list(materials)
    for i in range(draw(st.integers(1, 5))):
        kind = draw(pick(["quad", "box", "sphere", "mesh"] if mesh_refs else ["quad", "box", "sphere"]))
        o: dict = {"type": kind, "name": f"o{i}"}
        if names and draw(st.integers(0, 4)):
            o["material"] = draw(pick(names))
        if kind == "quad":
            o["center" if draw(st.booleans()) else "corner"] = draw(vec)
            o["u"], o["v"] = [draw(positive), 0, 0], [0, 0, -draw(positive)]
        elif kind == "box":
            o["center"] = draw(vec)
            o["size"] = draw(st.one_of(positive, st.lists(positive, min_size=3, max_size=3)))
        elif kind == "sphere":
            o["center"], o["radius"] = draw(vec), draw(positive)
        else:
            name, mesh_files, _ = draw(reference(f"mesh{i}", mesh_content()))
            if name.endswith(".ply") and draw(rarely(4)):
                name = draw(pick(["mesh_clean.ply", "mesh_dirty.ply", "tilted_normals.ply"]))
            o["file"] = name
            files.update(mesh_files)
        if draw(rarely(4)):
            o["translate"] = draw(vec)
        if draw(rarely(4)):
            o["rotate"] = [draw(st.floats(-180, 180)) for _ in range(3)]
        if draw(rarely(5)):
            o["scale"] = draw(st.one_of(positive, st.lists(positive, min_size=3, max_size=3)))
        if draw(rarely(6)):
            o["motion"] = {"translate": draw(vec)}
        if kind in ("quad", "box", "mesh") and draw(rarely(7)):
            o["prototype"] = True
        objects.append(o)
    doc["objects"] = objects
    meshes = [o["name"] for o in objects if o["type"] != "sphere"]
    if meshes and draw(rarely(4)):
        instances = []
        for _ in range(draw(st.integers(1, 3))):
            inst: dict = {"mesh": draw(pick(meshes))}
            if draw(st.booleans()):
                t = draw(vec)
                inst["transform"] = [[1, 0, 0, t[0]], [0, 1, 0, t[1]], [0, 0, 1, t[2]], [0, 0, 0, 1]]
            else:
                inst["translate"] = draw(vec)
            instances.append(inst)
        doc["instances"] = instances
    return doc, files


@functools.lru_cache(maxsize=None)
def mesh_content():
    return st.one_of(ply_content(), obj_content(), gltf_mesh_content(), st.just((".ply", b"")))


@st.composite
def gltf_mesh_content(draw):
    binary = draw(st.booleans())
    doc, blob, files = draw(gltf_parts(binary))
    text = _json_with_deep(doc)
    if binary:
        return ".glb", glb_pack(text, blob)
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    return ".gltf", _json_with_deep(doc).encode()


@st.composite
def toml_document_case(draw, build, name: str, tables_of_tables=("materials", "params")):
    """A TOML document from `build` (a strategy of (doc, files)), broken and damaged."""
    doc, files = draw(build)
    doc, edits = draw(broken_tree(doc))
    text = toml_text(doc, tables_of_tables)
    if draw(rarely(9)):
        text = draw(repeated_key(text))
        edits.append("repeated key")
    data, op = draw(damaged(text))
    return Case(data, files, _how(name, edits, op))


# ---- corpus ---------------------------------------------------------------------------------

@st.composite
def seeded(draw, seeds):
    """A corpus case (fuzz_corpus.Seed), its main file mutated by token_mutate."""
    seed = draw(pick(seeds))
    case = seed.case()
    if not isinstance(case.main, bytes):
        return case
    data = token_mutate(case.main, draw(st.randoms(use_true_random=False)))
    return Case(data, dict(case.files), f"seed {seed.name}, token edits", name=case.name)


def with_seeds(structured, target_name: str, weight: int = 3):
    """`structured` most of the time, a mutated corpus seed of the target otherwise."""
    from fuzz_corpus import seeds_for

    seeds = seeds_for(target_name, mutable=True)
    if not seeds:
        return structured
    return st.one_of(*([structured] * weight), seeded(seeds))


# ---- the targets' strategies ----------------------------------------------------------------

def toml_scenes():
    return with_seeds(toml_document_case(toml_scene_doc(), "toml scene"), "TOML scene")


# pbrt: a statement list. A statement: (directive, positional arguments, parameters), a
# parameter (type, name, values).

def _pbrt_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace('"', "") + '"'
    if isinstance(v, bool):
        return '"true"' if v else '"false"'
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, Deep):
        return "[" * v.depth + "]" * v.depth
    if isinstance(v, Huge):
        return " ".join([_pbrt_value(v.item if not isinstance(v.item, list) else 0)] * v.count)
    if isinstance(v, dict):
        return "[ ]"
    if isinstance(v, (list, tuple)):
        return "[ " + " ".join(_pbrt_value(x) for x in v) + " ]"
    return str(v)


def pbrt_text(statements) -> str:
    lines = []
    for name, args, params in statements:
        parts = [name] + [_pbrt_value(a) for a in args]
        for p in params:
            if len(p) == 3:
                ptype, pname, values = p
                parts.append(f'"{ptype} {pname}"')
                parts.append(_pbrt_value(values if isinstance(values, (list, Deep, Huge)) else [values]))
            else:
                parts.append(_pbrt_value(p[0]))
        lines.append(" ".join(parts))
    return "\n".join(lines) + "\n"


def _rgb(draw, lo=0.0, hi=1.0):
    return [draw(st.floats(lo, hi)) for _ in range(3)]


@st.composite
def pbrt_material(draw):
    kind = draw(pick(["matte", "plastic", "metal", "glass", "mirror", "substrate", "uber", "disney"]))
    params = []
    if kind in ("matte", "plastic", "substrate", "uber"):
        params.append(("rgb", "Kd", _rgb(draw)))
    if kind in ("plastic", "substrate"):
        params.append(("rgb", "Ks", _rgb(draw)))
    if kind in ("plastic", "metal", "substrate") and draw(st.booleans()):
        params.append(("float", "roughness", [draw(st.floats(0, 1))]))
    if kind == "metal":
        params += [("rgb", "eta", _rgb(draw, 0.1, 3)), ("rgb", "k", _rgb(draw, 0, 5))]
    if kind == "glass":
        params.append(("float", "index", [draw(st.floats(1, 2.5))]))
    return kind, params


@st.composite
def pbrt_shape(draw, files, depth=0):
    kind = draw(pick(["trianglemesh", "trianglemesh", "sphere", "plymesh"]))
    if kind == "sphere":
        return ("Shape", ["sphere"], [("float", "radius", [draw(positive)])])
    if kind == "plymesh":
        name, mesh_files, _ = draw(reference("mesh", ply_content()))
        if draw(rarely(3)):
            name = "tri.ply"  # the sibling of tests/data/fuzz
        files.update(mesh_files)
        return ("Shape", ["plymesh"], [("string", "filename", [name])])
    positions, faces, normals, uvs = draw(mesh_arrays())
    indices = [i for f in faces for i in f[:3]]
    params = [("integer", "indices", indices), ("point", "P", positions.reshape(-1).tolist())]
    if normals is not None:
        params.append(("normal", "N", normals.reshape(-1).tolist()))
    if uvs is not None:
        params.append(("float", "uv", uvs.reshape(-1).tolist()))
    return ("Shape", ["trianglemesh"], params)


@st.composite
def pbrt_world(draw, files, depth=0):
    out = []
    for _ in range(draw(st.integers(1, 6))):
        what = draw(pick(["shape", "shape", "material", "attribute", "transform", "area", "named",
                                     "texture", "object", "include", "light", "reverse"]))
        if what == "shape":
            out.append(draw(pbrt_shape(files)))
        elif what == "material":
            kind, params = draw(pbrt_material())
            out.append(("Material", [kind], params))
        elif what == "named":
            kind, params = draw(pbrt_material())
            out += [("MakeNamedMaterial", ["nm"], [("string", "type", [kind])] + params),
                    ("NamedMaterial", ["nm"], [])]
        elif what == "attribute" and depth < 3:
            out += [("AttributeBegin", [], [])] + draw(pbrt_world(files, depth + 1)) + [("AttributeEnd", [], [])]
        elif what == "transform":
            out.append(draw(pick([
                ("Translate", [draw(coords), draw(coords), draw(coords)], []),
                ("Scale", [draw(positive), draw(positive), draw(positive)], []),
                ("Rotate", [draw(st.floats(-180, 180)), 0.0, 1.0, 0.0], []),
                ("ConcatTransform", [[1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, draw(coords), 0, 0, 1.0]], []),
                ("Transform", [[1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, draw(coords), 0, 1.0]], []),
                ("CoordinateSystem", ["here"], []), ("CoordSysTransform", ["here"], []), ("Identity", [], [])])))
        elif what == "area":
            out += [("AttributeBegin", [], []),
                    ("AreaLightSource", ["diffuse"], [("rgb", "L", _rgb(draw, 0, 20))]),
                    draw(pbrt_shape(files)), ("AttributeEnd", [], [])]
        elif what == "texture":
            name, image_files, _ = draw(reference("tex", image_content(TEXTURE_IMAGES)))
            files.update(image_files)
            out += [("Texture", ["t", "spectrum", "imagemap"], [("string", "filename", [name])]),
                    ("Material", ["matte"], [("texture", "Kd", ["t"])])]
        elif what == "object":
            out += [("ObjectBegin", ["obj"], []), draw(pbrt_shape(files)), ("ObjectEnd", [], [])]
            out += [("ObjectInstance", ["obj"], [])] * draw(st.integers(1, 3))
        elif what == "include" and depth == 0:
            kind = draw(pick(["sibling", "sibling", "new", "self", "cycle", "fanout"]))
            if kind == "sibling":
                out.append(("Include", ["part.pbrt"], []))
            elif kind == "new":
                sub_files: dict = {}
                sub = pbrt_text(draw(pbrt_world(sub_files, depth + 1)))
                name, inc_files, _ = draw(reference("inc", st.just((".pbrt", sub.encode()))))
                files.update(sub_files)
                files.update(inc_files)
                out.append(("Include", [name], []))
            elif kind == "self":
                out.append(("Include", ["scene.pbrt"], []))
            elif kind == "cycle":
                files["cycle-a.pbrt"] = b'Include "cycle-b.pbrt"\n'
                files["cycle-b.pbrt"] = b'Include "cycle-a.pbrt"\n'
                out.append(("Include", ["cycle-a.pbrt"], []))
            else:  # each file includes the next twice: 2^levels includes in all
                levels = draw(st.integers(2, 12))
                for k in range(levels):
                    nxt = f'Include "fan{k + 1}.pbrt"\n' if k + 1 < levels else 'Shape "sphere"\n'
                    files[f"fan{k}.pbrt"] = (nxt * 2).encode()
                out.append(("Include", ["fan0.pbrt"], []))
        elif what == "light":
            if draw(st.booleans()):
                params = [("rgb", "L", _rgb(draw, 0, 3))]
                if draw(rarely(3)):
                    name, env_files, _ = draw(reference("sky", image_content(ENVIRONMENT_IMAGES)))
                    files.update(env_files)
                    params.append(("string", "mapname", [name]))
                out.append(("LightSource", ["infinite"], params))
            else:
                out.append(("LightSource", ["distant"], [("point", "from", [0.0, 1.0, 0.0]),
                                                          ("point", "to", [0.0, 0.0, 0.0]),
                                                          ("rgb", "L", _rgb(draw, 0, 5))]))
        elif what == "reverse":
            out.append(("ReverseOrientation", [], []))
    return out


@st.composite
def pbrt_doc(draw):
    files: dict = {}
    header = [("LookAt", [0.0, 1.0, 5.0, 0.0, draw(coords), 0.0, 0.0, 1.0, 0.0], []),
              ("Camera", ["perspective"], [("float", "fov", [draw(st.floats(10, 100))])]),
              ("Film", ["image"], [("integer", "xresolution", [draw(st.integers(1, 64))]),
                                   ("integer", "yresolution", [draw(st.integers(1, 64))])]),
              ("Sampler", ["halton"], [("integer", "pixelsamples", [16])]),
              ("Integrator", ["path"], [("integer", "maxdepth", [draw(st.integers(0, 10))])])]
    if draw(st.booleans()):
        kind = draw(pick(["box", "triangle", "gaussian", "mitchell"]))
        header.append(("PixelFilter", [kind], [("float", "xwidth", [draw(positive)]),
                                               ("float", "ywidth", [draw(positive)])]))
    header = [h for h in header if draw(st.integers(0, 6))]
    return header + [("WorldBegin", [], [])] + draw(pbrt_world(files)) + [("WorldEnd", [], [])], files


@st.composite
def broken_statements(draw, statements):
    statements = [(n, list(a), [tuple(p) for p in ps]) for n, a, ps in statements]
    edits = []
    for _ in range(draw(EDIT_COUNTS)):
        if not statements:
            break
        i = draw(st.integers(0, len(statements) - 1))
        name, args, params = statements[i]
        op = draw(pick(["value", "value", "type", "drop", "repeat", "swap", "bare", "args", "deep",
                                   "directive", "nest"]))
        if op == "value" and params:
            k = draw(st.integers(0, len(params) - 1))
            p = params[k]
            if len(p) == 3:
                values = list(p[2]) if isinstance(p[2], list) else [p[2]]
                if values and draw(st.booleans()):
                    values[draw(st.integers(0, len(values) - 1))] = draw(hostile_scalars)
                else:
                    values = draw(HOSTILE)
                params[k] = (p[0], p[1], values)
        elif op == "type" and params:
            k = draw(st.integers(0, len(params) - 1))
            p = params[k]
            if len(p) == 3:
                params[k] = (draw(pick(["float", "integer", "rgb", "spectrum", "string", "bool", "point",
                                                   "normal", "texture", "point2", "blackbody", "xyz", "color",
                                                   "", "float float"])), p[1], p[2])
        elif op == "drop":
            del statements[i]
        elif op == "repeat":
            statements.insert(i, statements[i])
        elif op == "swap":
            j = draw(st.integers(0, len(statements) - 1))
            statements[i], statements[j] = statements[j], statements[i]
        elif op == "bare" and params:  # the values without their brackets, or a lone name
            k = draw(st.integers(0, len(params) - 1))
            params[k] = (draw(pick(['"float"', '"rgb L"', '"integer indices"'])),)
        elif op == "args":
            statements[i] = (name, [draw(hostile_scalars) for _ in range(draw(st.integers(0, 10)))], params)
        elif op == "deep":
            statements[i] = (name, [Deep(draw(pick([100, 5000])))], params)
        elif op == "directive":
            statements.insert(i, (draw(pick(
                ["AttributeEnd", "AttributeBegin", "WorldBegin", "ObjectEnd", "ObjectInstance", "TransformEnd",
                 "Include", "Import", "MakeNamedMedium", "MediumInterface", "ActiveTransform", "TransformTimes",
                 "Texture", "NamedMaterial", "Camera", "Shape", "LightSource", "CoordSysTransform", "Frobnicate"])),
                [draw(hostile_scalars)] if draw(st.booleans()) else [], []))
        else:  # nest deeply
            depth = draw(pick([100, 2000, 20000]))
            statements[i:i] = [("AttributeBegin", [], [])] * depth + [("AttributeEnd", [], [])] * depth
        edits.append(f"{op} {name}")
    return statements, edits


@st.composite
def pbrt_case(draw):
    statements, files = draw(pbrt_doc())
    statements, edits = draw(broken_statements(statements))
    if draw(rarely(21)):  # many instances of one object
        count = draw(pick([1000, 20000]))
        statements += [("AttributeBegin", [], []), ("ObjectBegin", ["many"], []),
                       ("Shape", ["sphere"], [("float", "radius", [0.1])]), ("ObjectEnd", [], []),
                       ("AttributeEnd", [], [])] + [("ObjectInstance", ["many"], [])] * count
        edits.append(f"{count} instances")
    data, op = draw(damaged(pbrt_text(statements)))
    return Case(data, files, _how("pbrt", edits, op))


def pbrt_scenes():
    return with_seeds(pbrt_case(), "pbrt scene")


# Mitsuba: an element tree of (tag, attributes, children).

def _xml_attr(v) -> str:
    s = v if isinstance(v, str) else toml_value(v).strip('"')
    s = "".join(ch for ch in s if ch in "\t\n\r" or ord(ch) >= 0x20)
    return s.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def xml_text(node, indent=0) -> str:
    if isinstance(node, Deep):
        return "<bsdf type=\"twosided\">" * node.depth + "</bsdf>" * node.depth
    tag, attrs, children = node
    pad = "  " * indent
    attr_text = "".join(f' {k}="{_xml_attr(v)}"' for k, v in attrs.items())
    if not children:
        return f"{pad}<{tag}{attr_text}/>"
    inner = "\n".join(xml_text(c, indent + 1) for c in children)
    return f"{pad}<{tag}{attr_text}>\n{inner}\n{pad}</{tag}>"


def _xyz(v):
    return ", ".join(repr(float(x)) for x in v)


def _mi_transform(draw):
    ops = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(pick(["translate", "scale", "rotate", "matrix", "lookat"]))
        if kind == "translate":
            ops.append(("translate", {"x": draw(coords), "y": draw(coords), "z": draw(coords)}, []))
        elif kind == "scale":
            ops.append(("scale", {"value": draw(positive)}, []))
        elif kind == "rotate":
            ops.append(("rotate", {"y": 1, "angle": draw(st.floats(-180, 180))}, []))
        elif kind == "matrix":
            ops.append(("matrix", {"value": f"1 0 0 {draw(coords)} 0 1 0 0 0 0 1 0 0 0 0 1"}, []))
        else:
            ops.append(("lookat", {"origin": "0, 1, 4", "target": "0, 1, 0", "up": "0, 1, 0"}, []))
    return ("transform", {"name": "to_world"}, ops)


@st.composite
def mitsuba_bsdf(draw, files, depth=0):
    kind = draw(pick(["diffuse", "conductor", "roughconductor", "dielectric", "roughdielectric",
                                 "thindielectric", "plastic", "roughplastic", "twosided", "principled", "mask"]))
    children = []
    if kind == "diffuse":
        if draw(rarely(4)):
            name, image_files, _ = draw(reference("tex", image_content(TEXTURE_IMAGES)))
            files.update(image_files)
            children.append(("texture", {"type": "bitmap", "name": "reflectance"},
                             [("string", {"name": "filename", "value": name}, [])]))
        else:
            children.append(("rgb", {"name": "reflectance", "value": _xyz(_rgb(draw))}, []))
    elif kind in ("conductor", "roughconductor"):
        children.append(("string", {"name": "material", "value": draw(pick(["Au", "Ag", "Cu", "Al",
                                                                                          "none", "Xx"]))}, []))
        if kind == "roughconductor":
            children.append(("float", {"name": "alpha", "value": draw(st.floats(0, 1))}, []))
    elif kind in ("dielectric", "roughdielectric", "thindielectric"):
        children.append(("float", {"name": "int_ior", "value": draw(st.floats(1, 2.5))}, []))
    elif kind in ("plastic", "roughplastic"):
        children.append(("rgb", {"name": "diffuse_reflectance", "value": _xyz(_rgb(draw))}, []))
    elif kind == "twosided" and depth < 2:
        children.append(draw(mitsuba_bsdf(files, depth + 1)))
    return ("bsdf", {"type": kind}, children)


@st.composite
def mitsuba_doc(draw):
    files: dict = {}
    children = [("default", {"name": "res", "value": str(draw(st.integers(1, 64)))}, [])]
    children.append(("integrator", {"type": draw(pick(["path", "direct", "volpath"]))},
                     [("integer", {"name": "max_depth", "value": draw(st.integers(-1, 12))}, [])]))
    sensor = [("float", {"name": "fov", "value": draw(st.floats(10, 100))}, []),
              ("string", {"name": "fov_axis", "value": draw(pick(["x", "y", "smaller", "diagonal"]))}, []),
              ("transform", {"name": "to_world"}, [("lookat", {"origin": _xyz([0, 1, 4 + draw(positive)]),
                                                               "target": "0, 1, 0", "up": "0, 1, 0"}, [])]),
              ("film", {"type": "hdrfilm"}, [("integer", {"name": "width", "value": "$res"}, []),
                                             ("integer", {"name": "height", "value": str(draw(st.integers(1, 64)))},
                                              [])]
               + ([("rfilter", {"type": draw(pick(["box", "tent", "gaussian"]))}, [])]
                  if draw(st.booleans()) else []))]
    children.append(("sensor", {"type": draw(pick(["perspective", "perspective", "thinlens"]))}, sensor))
    children.append(("bsdf", {"type": "diffuse", "id": "white"}, [("rgb", {"name": "reflectance",
                                                                         "value": "0.7, 0.7, 0.7"}, [])]))
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(pick(["rectangle", "cube", "sphere", "disk", "obj", "ply"]))
        shape = []
        if kind == "sphere":
            shape += [("point", {"name": "center", "x": draw(coords), "y": draw(coords), "z": draw(coords)}, []),
                      ("float", {"name": "radius", "value": draw(positive)}, [])]
        elif kind in ("obj", "ply"):
            name, mesh_files, _ = draw(reference("mesh", obj_content() if kind == "obj" else ply_content()))
            files.update(mesh_files)
            shape.append(("string", {"name": "filename", "value": name}, []))
        if draw(st.booleans()):
            shape.append(_mi_transform(draw))
        shape.append(("ref", {"id": "white"}, []) if draw(st.booleans()) else draw(mitsuba_bsdf(files)))
        if draw(rarely(4)):
            shape.append(("emitter", {"type": "area"}, [("rgb", {"name": "radiance",
                                                                 "value": _xyz(_rgb(draw, 0, 20))}, [])]))
        children.append(("shape", {"type": kind}, shape))
    emitter = draw(pick(["constant", "envmap", "directional", None]))
    if emitter == "constant":
        children.append(("emitter", {"type": "constant"}, [("rgb", {"name": "radiance", "value": "0.5"}, [])]))
    elif emitter == "envmap":
        name, env_files, _ = draw(reference("sky", image_content(ENVIRONMENT_IMAGES)))
        files.update(env_files)
        children.append(("emitter", {"type": "envmap"}, [("string", {"name": "filename", "value": name}, []),
                                                         ("float", {"name": "scale", "value": draw(positive)}, [])]))
    elif emitter == "directional":
        children.append(("emitter", {"type": "directional"}, [
            ("vector", {"name": "direction", "x": 0, "y": -1, "z": draw(coords)}, []),
            ("rgb", {"name": "irradiance", "value": _xyz(_rgb(draw, 0, 5))}, [])]))
    if draw(rarely(5)):
        kind = draw(pick(["new", "self", "cycle", "loop"]))
        if kind == "new":
            sub = '<scene version="3.0.0">\n  <shape type="cube"/>\n</scene>\n'
            name, inc_files, _ = draw(reference("inc", st.just((".xml", sub.encode()))))
            files.update(inc_files)
        elif kind == "self":
            name = "scene.xml"
        elif kind == "cycle":
            name = "cyc-a.xml"
            files["cyc-a.xml"] = b'<scene version="3.0.0"><include filename="cyc-b.xml"/></scene>\n'
            files["cyc-b.xml"] = b'<scene version="3.0.0"><include filename="cyc-a.xml"/></scene>\n'
        else:
            name = "link-a.xml"
            files["link-a.xml"], files["link-b.xml"] = Link("link-b.xml"), Link("link-a.xml")
        children.append(("include", {"filename": name}, []))
    return ("scene", {"version": draw(pick(["3.0.0"] * 6 + ["0.6.0", "2.0.0", "x", ""]))}, children), files


@st.composite
def broken_xml(draw, root):
    root = copy.deepcopy(root)

    def to_lists(n):
        return [n[0], dict(n[1]), [to_lists(c) for c in n[2]]]

    def to_tuples(n):
        return (n[0], n[1], [to_tuples(c) for c in n[2]]) if isinstance(n, list) else n

    tree = to_lists(root)
    edits = []
    for _ in range(draw(EDIT_COUNTS)):
        nodes = []

        def walk(n, parent):
            nodes.append((n, parent))
            for c in n[2]:
                if isinstance(c, list):
                    walk(c, n)
        walk(tree, None)
        node, parent = draw(pick(nodes))
        op = draw(pick(["attr", "attr", "number", "dropattr", "drop", "repeat", "tag", "ref", "deep",
                                   "var", "move"]))
        if op in ("attr", "number") and node[1]:
            key = draw(pick(sorted(node[1])))
            node[1][key] = draw(hostile_numbers) if op == "number" else draw(st.one_of(
                hostile_scalars, pick(["1, 2", "1 2 3 4", "nan, nan, nan", "-10, -10, -10",
                                                  "1e39", "0, 0, 0", "$undefined", "$res$res"])))
        elif op == "dropattr" and node[1]:
            del node[1][draw(pick(sorted(node[1])))]
        elif op == "drop" and parent is not None:
            parent[2].remove(node)
        elif op == "repeat" and parent is not None:
            parent[2].insert(parent[2].index(node), copy.deepcopy(node))
        elif op == "tag":
            node[0] = draw(pick(["shape", "bsdf", "emitter", "texture", "transform", "float", "rgb",
                                            "spectrum", "include", "ref", "default", "boolean", "integer", "string",
                                            "point", "vector", "matrix", "medium", "phase", "volume", "alias",
                                            "thing", "scene"]))
        elif op == "ref":
            node[2].append(["ref", {"id": draw(pick(["white", "nothing", "", "$res"]))}, []])
        elif op == "deep":
            node[2].append(Deep(draw(pick([100, 3000, 50000]))))
        elif op == "var":
            node[1][draw(pick(["value", "type", "name", "id"]))] = "$res"
        elif op == "move" and parent is not None:
            parent[2].remove(node)
            tree[2].insert(0, node)
        edits.append(f"{op} <{node[0]}>")
    return to_tuples(tree), edits


XML_HOSTILE_PROLOGUES = [
    '<!DOCTYPE scene [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">'
    '<!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;"><!ENTITY d "&c;&c;&c;&c;&c;&c;&c;&c;&c;&c;">'
    '<!ENTITY e "&d;&d;&d;&d;&d;&d;&d;&d;&d;&d;"><!ENTITY f "&e;&e;&e;&e;&e;&e;&e;&e;&e;&e;">'
    '<!ENTITY g "&f;&f;&f;&f;&f;&f;&f;&f;&f;&f;">]>',
    '<!DOCTYPE scene [<!ENTITY x SYSTEM "file:///etc/passwd">]>',
    '<!DOCTYPE scene SYSTEM "http://example.invalid/x.dtd">',
    '<?xml-stylesheet href="x"?>',
]


@st.composite
def mitsuba_case(draw):
    root, files = draw(mitsuba_doc())
    root, edits = draw(broken_xml(root))
    text = '<?xml version="1.0" encoding="utf-8"?>\n' + xml_text(root) + "\n"
    if draw(rarely(16)):
        prologue = draw(pick(XML_HOSTILE_PROLOGUES))
        entity = "&g;" if "ENTITY g" in prologue else "&x;" if "ENTITY x" in prologue else ""
        text = text.replace("?>\n", "?>\n" + prologue + "\n", 1).replace('value="0.7, 0.7, 0.7"',
                                                                         f'value="{entity}0.7"', 1)
        edits.append("prologue")
    data, op = draw(damaged(text, comment="<!-- -->"))
    return Case(data, files, _how("xml", edits, op))


def mitsuba_scenes():
    return with_seeds(mitsuba_case(), "Mitsuba XML scene")


def gltf_scenes():
    return with_seeds(st.one_of(gltf_cases(False), gltf_cases(True)), "glTF scene")


@st.composite
def obj_case(draw):
    files = {}
    mtl = None
    if draw(rarely(3)):
        tex, tex_files, _ = draw(reference("skin", image_content(TEXTURE_IMAGES)))
        mtl, mtl_files, _ = draw(reference("skin", st.just((".mtl", _mtl_text(tex).encode("utf-8", "replace")))))
        files.update(tex_files)
        files.update(mtl_files)
    data, op = draw(damaged(draw(obj_text(mtl))))
    return Case(data, files, _how("obj", op))


def obj_meshes():
    return with_seeds(obj_case(), "OBJ mesh")


@st.composite
def ply_case(draw):
    data, broken = draw(ply_text())
    data, op = draw(damaged_bytes(data) if b"binary" in data[:64] else damaged(data.decode("latin-1")))
    return Case(data, {}, _how("ply", broken, op))


def ply_meshes():
    return with_seeds(ply_case(), "PLY mesh")


# Images: a fixed scene that names the fuzzed file.

TEXTURE_SCENE = """\
[camera]
position = [0, 0, 3]
target = [0, 0, 0]

[environment]
radiance = 1

[materials.textured]
texture = "{name}"

[[objects]]
type = "quad"
material = "textured"
center = [0, 0, 0]
u = [1, 0, 0]
v = [0, 1, 0]
"""

ENVIRONMENT_SCENE = """\
[camera]
position = [0, 0, 3]
target = [0, 0, 0]

[environment]
radiance = [1, 0.5, 2]
map = "{name}"

[[objects]]
type = "sphere"
radius = 0.5
"""


@st.composite
def image_case(draw, scene: str, kinds, stem: str):
    name, files, what = draw(reference(stem, image_content(kinds)))
    for k, v in list(files.items()):
        if isinstance(v, bytes) and draw(rarely(6)):
            files[k], op = draw(damaged_bytes(v))
            what = _how(what, op)
    text = scene.format(name=name.replace("\\", "\\\\").replace('"', '\\"').replace("\x00", "\\u0000"))
    return Case(text.encode(), files, _how(stem, name, what))


def texture_cases():
    return with_seeds(image_case(TEXTURE_SCENE, TEXTURE_IMAGES, "texture"), "texture image", weight=6)


def environment_cases():
    return with_seeds(image_case(ENVIRONMENT_SCENE, ENVIRONMENT_IMAGES, "sky"), "environment map", weight=6)


@st.composite
def reference_image_case(draw):
    kind = draw(pick(["png", "exr", "exr", "pfm", "pfm", "npy"]))
    size = draw(pick([(8, 8)] * 4 + [(16, 16), (24, 24), (8, 16), (7, 7), (1, 1)]))
    maker = {"png": png_bytes, "exr": exr_bytes, "pfm": pfm_bytes, "npy": npy_bytes}[kind]
    ext, data = draw(maker(*size))
    if draw(rarely(5)):
        data, _ = draw(damaged_bytes(data))
    special = draw(pick([None] * 20 + ["devzero", "folder", "fifo", "loop", "missing"]))
    main = {None: data, "devzero": Link("/dev/zero"), "folder": Folder(), "fifo": Fifo(),
            "loop": Link("reference" + ext)}.get(special, data)
    if special == "missing":
        return Case(Link("nowhere" + ext), {}, "reference missing", name="reference" + ext)
    return Case(main, {}, _how(f"reference {kind} {size}", special), name="reference" + ext)


def reference_cases():
    return with_seeds(reference_image_case(), "reference image", weight=6)


# Camera paths: keyframes and moves over fuzz_harness.camera_path_scene().

PATH_OBJECTS = ["floor", "glass sphere", "crate", "block 11", "ball", "nothing", ""]


@st.composite
def camera_path_doc(draw):
    keyframes = []
    t = draw(st.floats(-5, 5))
    for _ in range(draw(st.integers(1, 4))):
        position = draw(vec)
        if draw(rarely(9)):  # looking straight up or down: along the up vector
            target = [position[0], position[1] + draw(pick([5.0, -5.0, 1e-9])), position[2]]
        else:
            target = [position[0] + draw(coords), position[1] + draw(coords), position[2] - draw(positive)]
        k = {"time": t, "position": position, "target": target}
        if draw(st.booleans()):
            k["fov"] = draw(st.floats(1, 170))
        keyframes.append(k)
        t += draw(st.floats(0.01, 3)) if not draw(rarely(8)) else draw(pick([1e-300, 5e-324, 0.0]))
    doc = {"keyframe": keyframes}
    if draw(st.booleans()):
        doc["move"] = [{"object": draw(pick(PATH_OBJECTS)), "velocity": draw(vec)}
                       for _ in range(draw(st.integers(1, 3)))]
    return doc, {}


def camera_paths():
    return with_seeds(toml_document_case(camera_path_doc(), "camera path"), "camera path")


# Plugin manifests, with their shaders.

GLSL_ENTRY = """\
// a fuzzed plugin
{includes}
vec3 radiance(Ray ray, Hit hit, inout Rng rng) {{
    if (hit.prim == NO_HIT) return vec3(0.0);
    return vec3({value});
}}
"""


@st.composite
def plugin_doc(draw):
    files: dict = {}
    includes = []
    for i in range(draw(st.integers(0, 3))):
        kind = draw(pick(["library", "local", "ref", "ref", "self", "cycle"]))
        if kind == "library":
            includes.append('#include "lift/sampling.glsl"')
        elif kind == "local":
            files[f"helper{i}.glsl"] = b"float helper_value() { return 0.5; }\n"
            includes.append(f'#include "helper{i}.glsl"')
        elif kind == "self":
            includes.append('#include "main.glsl"')
        elif kind == "cycle":
            files["loop-a.glsl"] = b'#include "loop-b.glsl"\n'
            files["loop-b.glsl"] = b'#include "loop-a.glsl"\n'
            includes.append('#include "loop-a.glsl"')
        else:
            name, inc_files, _ = draw(reference(f"inc{i}", st.just((".glsl", b"float x_value = 1.0;\n"))))
            files.update(inc_files)
            quote = draw(pick(['"{}"', "<{}>"]))
            includes.append("#include " + quote.format(name))
    params = {}
    for i in range(draw(st.integers(0, 3))):
        ptype = draw(pick(["float", "int", "bool", "color"]))
        default = {"float": draw(st.floats(0, 1)), "int": draw(st.integers(0, 8)), "bool": draw(st.booleans()),
                   "color": [draw(st.floats(0, 1)) for _ in range(3)]}[ptype]
        spec = {"type": ptype, "default": default, "help": "a parameter"}
        if ptype in ("float", "int") and draw(st.booleans()):
            spec.update({"min": 0, "max": 10})
        if ptype == "int" and draw(rarely(4)):
            spec["define"] = f"FUZZ_DEFINE_{i}"
        params[f"p{i}"] = spec
    entry_name, entry_files, _ = draw(reference("main", st.just((".glsl", GLSL_ENTRY.format(
        includes="\n".join(includes), value=draw(pick(["1.0", "0.5, 0.2, 0.1"]))).encode()))))
    if not draw(rarely(4)):
        entry_name, entry_files = "main.glsl", {"main.glsl": GLSL_ENTRY.format(
            includes="\n".join(includes), value="1.0").encode()}
    files.update(entry_files)
    doc = {"name": draw(pick(["fuzzed", "pt", "my_plugin", "x1"])), "description": "fuzzed plugin",
           "language": draw(pick(["glsl"] * 8 + ["opencl"])), "entry": entry_name,
           "primary": draw(pick(["gbuffer", "camera"]))}
    if draw(st.booleans()):
        doc["splats"] = draw(st.booleans())
    if draw(rarely(4)):
        doc["bvh_stack"] = draw(pick(["auto", "children", "groups"]))
    if draw(rarely(5)):
        doc["biased"] = "clamps fireflies"
    if params:
        doc["params"] = params
    if draw(rarely(6)):
        doc["reduced"] = {"function": "radiance", "scale": 2}
    return doc, files


def plugin_manifests():
    return with_seeds(toml_document_case(plugin_doc(), "manifest"), "plugin manifest")
