"""Reading one Mitsuba plugin's parameters: <float name=... value=.../>, <rgb>, <spectrum>,
<point>, <vector>, <boolean>, <integer>, <string>, <transform>, nested or referenced
<texture>s, with Mitsuba 0.5/0.6 camelCase names read as Mitsuba 3's snake_case.

`Props` remembers what the loader read, so that what it did not read can be reported
(once per plugin type and parameter, naming the line) instead of ignored silently.
"""
from __future__ import annotations

import re

import numpy as np

from ..errors import SceneError
from . import primitives as prim
from .validate import affine_problem
from .xml_tree import Node

PROPERTY_TAGS = {"float", "integer", "boolean", "string", "rgb", "srgb", "spectrum", "point",
                 "vector", "transform", "blackbody"}
# Child elements that are plugins of their own (read by the loader where they belong).
PLUGIN_TAGS = {"bsdf", "texture", "ref", "emitter", "film", "sampler", "rfilter", "integrator",
               "sensor", "shape", "medium", "phase"}


def snake_case(name: str) -> str:
    """Mitsuba 0.5's camelCase parameter names in Mitsuba 3's spelling: toWorld -> to_world,
    intIOR -> int_ior, maxDepth -> max_depth (what Mitsuba 3's own upgrade does)."""
    return re.sub(r"(?<=[a-z0-9])([A-Z]+)", r"_\1", name).lower()


def _numbers(text: str, node: Node) -> list[float]:
    try:
        return [float(x) for x in re.split(r"[,\s]+", text.strip()) if x]
    except ValueError:
        raise SceneError(f"<{node.tag} name=\"{node.get('name')}\">: '{text}' is not a list of numbers",
                         *node.where) from None


def parse_color(node: Node, warn) -> np.ndarray:
    """An <rgb>, <srgb> or <spectrum> element as linear RGB."""
    value = node.get("value")
    if node.tag == "blackbody" or (node.tag == "spectrum" and value is None):
        warn(node, f"<{node.tag}> values are not supported; using grey 1")
        return np.ones(3)
    if value is None:
        raise SceneError(f"<{node.tag} name=\"{node.get('name')}\"> has no value", *node.where)
    text = value.strip()
    if text.startswith("#"):
        if not re.fullmatch(r"#[0-9a-fA-F]{6}", text):
            raise SceneError(f"'{text}' is not a #rrggbb colour", *node.where)
        from ..tonemap import srgb_decode
        return srgb_decode(np.array([int(text[i:i + 2], 16) for i in (1, 3, 5)]) / 255.0)
    if node.tag == "spectrum" and ":" in text:
        pairs = [p.split(":") for p in re.split(r"[,\s]+", text) if p]
        try:
            values = [float(v) for _, v in pairs]
        except ValueError:
            raise SceneError(f"'{text}' is not a list of wavelength:value pairs", *node.where) from None
        warn(node, "sampled spectra are approximated by their mean value (grey)")
        return np.full(3, float(np.mean(values)))
    numbers = _numbers(text, node)
    if len(numbers) == 1:
        rgb = np.full(3, numbers[0])
    elif len(numbers) == 3:
        rgb = np.asarray(numbers)
    else:
        raise SceneError(f"<{node.tag} name=\"{node.get('name')}\"> needs 1 or 3 values, got {len(numbers)}",
                         *node.where)
    if node.tag == "srgb":
        from ..tonemap import srgb_decode
        rgb = srgb_decode(rgb)
    return rgb


def parse_vector(node: Node) -> np.ndarray:
    """<point>/<vector> with x, y, z attributes or value="x, y, z"."""
    if node.get("value") is not None:
        v = _numbers(node.get("value"), node)
        if len(v) == 1:
            v = v * 3
        if len(v) != 3:
            raise SceneError(f"<{node.tag}> needs 3 values", *node.where)
        return np.asarray(v)
    return np.array([_float_attr(node, k, 0.0) for k in "xyz"])


def _float_attr(node: Node, key: str, default: float) -> float:
    text = node.get(key)
    if text is None:
        return default
    try:
        return float(text)
    except ValueError:
        raise SceneError(f"<{node.tag}>: {key}=\"{text}\" is not a number", *node.where) from None


def parse_transform(node: Node, warn) -> np.ndarray:
    """<transform>: its children applied in order, each one after the previous ones."""
    m = np.eye(4)
    for op in node.children:
        if op.tag == "translate":
            t = prim.translate_matrix(parse_vector(op))
        elif op.tag == "scale":
            if op.get("value") is not None:
                t = prim.scale_matrix(parse_vector(op))
            else:
                t = prim.scale_matrix([_float_attr(op, k, 1.0) for k in "xyz"])
        elif op.tag == "rotate":
            axis = parse_vector(op)
            if not np.linalg.norm(axis) > 0:
                raise SceneError("<rotate> needs a non-zero axis", *op.where)
            t = prim.axis_angle_matrix(_float_attr(op, "angle", 0.0), axis)
        elif op.tag == "matrix":
            v = _numbers(op.get("value", ""), op)
            if len(v) == 16:
                t = np.asarray(v).reshape(4, 4)  # row-major
            elif len(v) == 9:
                t = np.eye(4)
                t[:3, :3] = np.asarray(v).reshape(3, 3)
            else:
                raise SceneError(f"<matrix> needs 16 (or 9) values, got {len(v)}", *op.where)
            problem = affine_problem(t)
            if problem:
                raise SceneError(f"<matrix>: {problem}", *op.where)
        elif op.tag == "lookat":
            t = lookat_matrix(op)
        else:
            warn(op, f"unknown transform element <{op.tag}>; ignored")
            continue
        m = t @ m
    return m


def lookat_matrix(op: Node) -> np.ndarray:
    """Mitsuba's lookat: +z towards the target, +y towards up, +x = up x dir (the image's
    left for a camera)."""
    def vec(key, default):
        text = op.get(key)
        if text is None:
            if default is None:
                raise SceneError(f"<lookat> needs '{key}'", *op.where)
            return np.asarray(default, dtype=np.float64)
        v = _numbers(text, op)
        if len(v) != 3:
            raise SceneError(f"<lookat> '{key}' needs 3 values", *op.where)
        return np.asarray(v)

    origin, target, up = vec("origin", None), vec("target", None), vec("up", [0, 1, 0])
    d = target - origin
    left = np.cross(up, d)
    if not (np.linalg.norm(d) > 0 and np.linalg.norm(left) > 0):
        raise SceneError("<lookat>: origin equals target, or up is parallel to the view", *op.where)
    d /= np.linalg.norm(d)
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, origin
    return m


class Props:
    """The parameters of one plugin element."""

    def __init__(self, node: Node, warn):
        self.node = node
        self.warn = warn
        self.items: dict[str, Node] = {}
        self.used: set[str] = set()
        for child in node.children:
            name = child.get("name")
            if name is not None and (child.tag in PROPERTY_TAGS or child.tag in ("texture", "ref")):
                self.items[snake_case(name)] = child

    @property
    def kind(self) -> str:
        return self.node.get("type", "")

    def has(self, name: str) -> bool:
        return name in self.items

    def _take(self, name: str, tags) -> Node | None:
        node = self.items.get(name)
        if node is None:
            return None
        self.used.add(name)
        if node.tag not in tags:
            raise SceneError(f"parameter '{name}' of {self.node.tag} '{self.kind}' should be "
                             f"<{'> or <'.join(sorted(tags))}>, not <{node.tag}>", *node.where)
        return node

    def _value(self, node: Node) -> str:
        value = node.get("value")
        if value is None:
            raise SceneError(f"<{node.tag} name=\"{node.get('name')}\"> has no value", *node.where)
        return value

    def float(self, name: str, default=None):
        node = self._take(name, {"float", "integer"})
        if node is None:
            return default
        v = _numbers(self._value(node), node)
        if len(v) != 1:
            raise SceneError(f"'{name}' needs one number", *node.where)
        return v[0]

    def int(self, name: str, default=None):
        node = self._take(name, {"integer"})
        if node is None:
            return default
        try:
            return int(self._value(node))
        except ValueError:
            raise SceneError(f"'{name}' must be an integer, not '{node.get('value')}'", *node.where) from None

    def bool(self, name: str, default=False):
        node = self._take(name, {"boolean"})
        if node is None:
            return default
        value = self._value(node).strip().lower()
        if value not in ("true", "false"):
            raise SceneError(f"'{name}' must be true or false, not '{node.get('value')}'", *node.where)
        return value == "true"

    def string(self, name: str, default=None):
        node = self._take(name, {"string"})
        return default if node is None else self._value(node)

    def vector(self, name: str, default=None):
        node = self._take(name, {"point", "vector"})
        return (None if default is None else np.asarray(default, dtype=np.float64)) if node is None \
            else parse_vector(node)

    def transform(self, name: str = "to_world") -> np.ndarray:
        node = self._take(name, {"transform"})
        return np.eye(4) if node is None else parse_transform(node, self.warn)

    def color_node(self, name: str) -> Node | None:
        """The element of a colour parameter: <rgb>, <spectrum>, <texture> or <ref>."""
        return self._take(name, {"rgb", "srgb", "spectrum", "blackbody", "float", "texture", "ref"})

    def warn_unused(self, ignore=()):
        for child in self.node.children:
            if child.tag not in PROPERTY_TAGS and child.tag not in PLUGIN_TAGS:
                self.warn(child, f"unknown element <{child.tag}> in {self.node.tag} '{self.kind}'; ignored",
                          key=("element", child.tag))
        for name, node in self.items.items():
            if name not in self.used and name not in ignore:
                self.warn(node, f"{self.node.tag} '{self.kind}': parameter '{name}' is not supported; ignored",
                          key=(self.node.tag, self.kind, name))
