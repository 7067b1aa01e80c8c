"""A pbrt-v3 scene subset: tokenizer, statement parser, parameter lists, graphics state.

Layers, so the rest of the subset slots in later: `tokenize` (text -> tokens with lines),
`statements` (tokens -> directive + arguments), `ParamSet` (the "type name" [values]
lists, with typed getters that remember what was used), and `_Builder` (one method per
directive, keeping pbrt's graphics state and filling the Scene).

Conventions and assumptions:
- pbrt's camera looks down +z with +x to the image's right and +y up (a left-handed
  frame). Our Camera derives right = cross(forward, up); where that disagrees with pbrt's
  +x (e.g. a plain LookAt), the whole world is mirrored in x so the image is not.
- `fov` is for the shorter image axis; Camera.fov_deg is vertical, converted when w < h.
- Integrator `maxdepth` is kept as Scene.max_depth unchanged: the number of bounces
  (scattering events) a path may have, as in pbrt (0: only light seen directly).
- Front faces follow pbrt: the geometric normal, flipped by ReverseOrientation or a
  mirroring transform, and turned towards the shading normals N where a mesh has them.
- ObjectBegin/ObjectEnd define an object's shapes once; each ObjectInstance places its
  meshes as instances (Scene.instances: one BVH per mesh, docs/instancing.md) and copies
  its spheres.
- `PixelFilter` box, triangle and gaussian are kept (Scene.pixel_filter, radii in the film's
  pixels; renders importance-sample it); mitchell and sinc, whose negative lobes cannot be
  sampled as a density, warn and fall back to a box. Sampler, Accelerator and Film's
  filename are ignored on purpose: the renderer has its own sampling. Everything else that
  cannot be honoured warns.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import LiftError, SceneError
from ..limits import MAX_INSTANCES, IncludeBudget, check_instance_count
from . import primitives as prim
from .loader import internal_error, warn_at
from .mesh_io import load_mesh_file
from .model import Camera, DistantLight, Environment, Instance, Material, Mesh, Scene, film_filter
from .optics import ior_from_f0
from .texture_files import FLOAT_EXTENSIONS, TextureLibrary, read_environment_image
from .validate import affine_problem

# --- tokens -------------------------------------------------------------------------------


@dataclass
class Token:
    kind: str  # "str", "num", "name", "[", "]"
    value: object
    line: int


_TOKEN = re.compile(r"""
    (?P<ws>[ \t\r\f\v]+) | (?P<nl>\n) | (?P<comment>\#[^\n]*)
  | (?P<str>"[^"\n]*") | (?P<open>\[) | (?P<close>\])
  | (?P<num>[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
""", re.VERBOSE)


def tokenize(text: str, path) -> list[Token]:
    tokens, line, pos = [], 1, 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            raise SceneError(f"unexpected character {text[pos]!r}", path, line)
        kind = m.lastgroup
        if kind == "nl":
            line += 1
        elif kind == "str":
            if "\0" in m.group():  # no file or name holds one (and Path refuses it)
                raise SceneError("a string holds a NUL character", path, line)
            tokens.append(Token("str", m.group()[1:-1], line))
        elif kind == "num":
            tokens.append(Token("num", float(m.group()), line))
        elif kind == "name":
            if m.group().lower() in ("nan", "inf", "infinity"):
                raise SceneError(f"'{m.group()}' is not a number lift-gl accepts: values must be finite", path, line)
            tokens.append(Token("name", m.group(), line))
        elif kind in ("open", "close"):
            tokens.append(Token("[" if kind == "open" else "]", None, line))
        pos = m.end()
    return tokens


@dataclass
class Statement:
    name: str
    args: list  # str, float, or list of str/float (a bracketed group)
    path: Path
    line: int


def statements(tokens: list[Token], path: Path):
    """Group tokens into directives: a name and every value up to the next name."""
    i = 0
    while i < len(tokens):
        t = tokens[i]
        if t.kind != "name":
            raise SceneError(f"expected a directive, found {t.value!r}", path, t.line)
        args, i = [], i + 1
        while i < len(tokens) and not _is_directive(tokens[i]):
            tok = tokens[i]
            if tok.kind == "[":
                group, i = [], i + 1
                while i < len(tokens) and tokens[i].kind != "]":
                    if tokens[i].kind == "[":
                        raise SceneError("nested '[' is not valid here", path, tokens[i].line)
                    if tokens[i].kind == "name" and not _is_bool(tokens[i]):
                        raise SceneError("missing ']'", path, tok.line)
                    group.append(tokens[i].value)
                    i += 1
                if i == len(tokens):
                    raise SceneError("missing ']'", path, tok.line)
                args.append(group)
            elif tok.kind == "]":
                raise SceneError("']' without '['", path, tok.line)
            else:
                args.append(tok.value)
            i += 1
        yield Statement(t.value, args, path, t.line)


def _is_bool(t: Token) -> bool:
    return t.kind == "name" and t.value in ("true", "false")


def _is_directive(t: Token) -> bool:
    return t.kind == "name" and not _is_bool(t)


# --- parameter lists --------------------------------------------------------------------

_TYPE_ALIASES = {"point3": "point", "normal3": "normal", "vector3": "vector", "color": "rgb"}


@dataclass
class Param:
    type: str
    values: list


@dataclass
class ParamSet:
    params: dict = field(default_factory=dict)
    used: set = field(default_factory=set)
    where: tuple = (None, None)

    @classmethod
    def parse(cls, args: list, st: Statement) -> "ParamSet":
        ps = cls(where=(st.path, st.line))
        if len(args) % 2:
            raise SceneError(f"{st.name}: parameter list must be \"type name\" value pairs",
                             st.path, st.line)
        for decl, value in zip(args[::2], args[1::2]):
            words = decl.split() if isinstance(decl, str) else []
            if len(words) != 2:
                raise SceneError(f"{st.name}: bad parameter declaration {decl!r} "
                                 "(expected \"type name\")", st.path, st.line)
            kind = _TYPE_ALIASES.get(words[0], words[0])
            ps.params[words[1]] = Param(kind, value if isinstance(value, list) else [value])
        return ps

    def _get(self, name, types, count=None):
        p = self.params.get(name)
        if p is None:
            return None
        self.used.add(name)
        if not p.values:
            raise SceneError(f"parameter '{name}' has no value (empty [ ])", *self.where)
        if p.type not in types:
            raise SceneError(f"parameter '{name}' should be {' or '.join(types)}, "
                             f"not {p.type}", *self.where)
        numeric = p.type not in ("string", "texture", "bool")
        if numeric and not all(isinstance(v, float) for v in p.values):
            raise SceneError(f"parameter '{name}' needs numbers", *self.where)
        if not numeric and not all(isinstance(v, str) for v in p.values):
            raise SceneError(f"parameter '{name}' ({p.type}) needs quoted strings", *self.where)
        if count is not None and len(p.values) % count:
            raise SceneError(f"parameter '{name}' needs a multiple of {count} values, "
                             f"got {len(p.values)}", *self.where)
        return p

    def float(self, name, default=None):
        p = self._get(name, ("float",))
        return default if p is None else p.values[0]

    def floats(self, name, count=1, types=("float",)):
        p = self._get(name, types, count)
        return None if p is None else np.asarray(p.values, dtype=np.float64).reshape(-1, count)

    def ints(self, name):
        p = self._get(name, ("integer",))
        if p is None:
            return None
        if not all(abs(v) < 2 ** 31 and v == int(v) for v in p.values):  # nan fails too
            raise SceneError(f"parameter '{name}' needs integers below 2^31", *self.where)
        return np.asarray(p.values, dtype=np.int64)

    def int(self, name, default=None):
        v = self.ints(name)
        return default if v is None else int(v[0])

    def string(self, name, default=None):
        p = self._get(name, ("string",))
        return default if p is None else p.values[0]

    def bool(self, name, default=False):
        p = self._get(name, ("bool",))
        if p is None:
            return default
        v = p.values[0]
        if v not in ("true", "false"):
            raise SceneError(f"parameter '{name}' must be true or false", *self.where)
        return v == "true"

    def spectrum(self, name, default):
        """RGB of an rgb/spectrum/texture parameter; what can't be read warns, uses default."""
        p = self.params.get(name)
        if p is None:
            return np.asarray(default, dtype=np.float64)
        if p.type == "rgb":
            return self.floats(name, 3, ("rgb",))[0]
        self.used.add(name)
        if p.type == "spectrum" and all(isinstance(v, float) for v in p.values) \
                and len(p.values) == 1:
            return np.full(3, p.values[0])
        what = {"texture": "textures are", "spectrum": "sampled/named spectra are",
                "blackbody": "blackbody spectra are"}.get(p.type, f"'{p.type}' values are")
        warn_at(*self.where, f"parameter '{name}': {what} not supported yet; using "
                f"{np.round(default, 3).tolist()}")
        return np.asarray(default, dtype=np.float64)

    def warn_unused(self, what: str, ignore=()):
        for name in self.params:
            if name not in self.used and name not in ignore:
                warn_at(*self.where, f"{what}: parameter '{name}' is not supported; ignored")


# --- materials --------------------------------------------------------------------------

COPPER = (np.array([0.200438, 0.924033, 1.102212]), np.array([3.912949, 2.452848, 2.142188]))


def roughness_to_alpha(r: float) -> float:
    """pbrt-v3's TrowbridgeReitzDistribution::RoughnessToAlpha: a fit in x = ln(r)."""
    x = np.log(max(r, 1e-3))
    return float(1.62142 + 0.819955 * x + 0.1734 * x**2 + 0.0171201 * x**3
                 + 0.000640711 * x**4)


def _alpha(ps: ParamSet, default_roughness: float, what: str) -> float:
    rough = ps.float("roughness", default_roughness)
    u, v = ps.float("uroughness", rough), ps.float("vroughness", rough)
    if ps.bool("remaproughness", True):
        u, v = roughness_to_alpha(u), roughness_to_alpha(v)
    if abs(u - v) > 1e-6:
        warn_at(*ps.where, f"{what}: anisotropic roughness is not supported; using the "
                "geometric mean of the two alphas")
    return float(np.sqrt(u * v))


def _grey(rgb) -> bool:
    rgb = np.asarray(rgb, dtype=np.float64)
    return bool(np.ptp(rgb) <= 1e-6 * max(float(rgb.max()), 1e-30))


def make_material(kind: str, ps: ParamSet, name: str, colour=None) -> Material:
    """`colour(ps, param, default)` -> (rgb, texture index or None) reads a parameter that
    may be a texture; without it, textures fall back to the default with a warning."""
    if colour is None:
        def colour(ps, param, default):
            return ps.spectrum(param, default), None
    src = f"{ps.where[0]}:{ps.where[1]}"
    what = f"material '{name}' ({kind})"
    if kind == "matte":
        kd, tex = colour(ps, "Kd", [0.5] * 3)
        m = Material(name, "diffuse", base_color=kd, texture=tex, source=src)
        if ps.float("sigma", 0.0) != 0.0:
            warn_at(*ps.where, f"{what}: Oren-Nayar sigma is not supported; Lambertian used")
    elif kind == "metal":
        eta, k = ps.spectrum("eta", COPPER[0]), ps.spectrum("k", COPPER[1])
        m = Material(name, "conductor", base_color=[1, 1, 1], eta=eta, k=k,
                     alpha=_alpha(ps, 0.01, what), source=src)
    elif kind == "glass":
        eta = ps.float("eta", None)
        eta = ps.float("index", 1.5) if eta is None else eta
        kr = ps.spectrum("Kr", [1, 1, 1])
        if np.any(kr != 1):
            warn_at(*ps.where, f"{what}: Kr other than 1 is not supported; ignored")
        m = Material(name, "dielectric", base_color=ps.spectrum("Kt", [1, 1, 1]), ior=eta,
                     alpha=_alpha(ps, 0.0, what), source=src)
    elif kind == "mirror":
        m = Material(name, "conductor", base_color=ps.spectrum("Kr", [0.9] * 3), alpha=0.0,
                     source=src)
    elif kind in ("substrate", "plastic"):
        # Both become the layered plastic: a diffuse base under a dielectric coat whose
        # normal-incidence reflectance is Ks (the coat's index follows from it), GGX alpha
        # from pbrt's roughness conventions. substrate (FresnelBlend) and plastic (Lambert
        # plus a Torrance-Sparrow lobe, diffuse not attenuated) differ from it in detail.
        default = 0.5 if kind == "substrate" else 0.25
        kd, tex = colour(ps, "Kd", [default] * 3)
        ks, _ = colour(ps, "Ks", [default] * 3)
        f0 = float(np.max(ks))
        if not _grey(ks):
            warn_at(*ps.where, f"{what}: a coloured Ks is approximated by a coat of "
                    f"reflectance {f0:.3g} tinted by Ks / {f0:.3g}")
        if kind == "plastic":
            warn_at(*ps.where, f"{what}: pbrt's plastic is approximated by a layered plastic "
                    "(its diffuse part is attenuated by the coat)")
        m = Material(name, "plastic", base_color=kd, texture=tex, ior=ior_from_f0(f0),
                     specular=np.asarray(ks) / max(f0, 1e-6) if f0 > 0 else np.zeros(3),
                     alpha=_alpha(ps, 0.1, what), source=src)
    else:
        warn_at(*ps.where, f"{what}: material type '{kind}' is not supported yet; "
                "approximated as diffuse with its Kd")
        kd, tex = colour(ps, "Kd", [0.5] * 3)
        m = Material(name, "diffuse", base_color=kd, texture=tex, source=src)
        ps.used.update(ps.params)  # already warned about the whole material
    ps.warn_unused(what, ignore=("type",))
    return m


# pbrt's infinite light maps direction p (light space, +z up) to u = phi / 2pi with
# phi = atan2(p.y, p.x), v = theta / pi, theta from +z. Environment (model.py) uses
# Mitsuba's mapping; the map-frame direction with the same (u, v) is m = PBRT_TO_MAP @ p.
PBRT_TO_MAP = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])

# --- the directive interpreter ----------------------------------------------------------


@dataclass
class _State:
    ctm: np.ndarray
    reverse: bool = False
    material: Material | None = None
    emission: np.ndarray | None = None
    emission_source: str = ""  # "file:line" of the AreaLightSource


IGNORED = {"Sampler", "Accelerator", "WorldEnd", "ColorSpace", "Option"}
# ObjectInstance as a directive: strings and comments are matched first, and skipped
_PLACEMENT = re.compile(r'"[^"\n]*"|#[^\n]*|\bObjectInstance\b')


class _Builder:
    def __init__(self, path: Path):
        self.root = path
        self.scene = Scene(camera=Camera(position=[0, 0, 0], target=[0, 0, 1]))
        self.state = _State(ctm=np.eye(4), material=Material("pbrt-default", "diffuse",
                                                            base_color=[0.5] * 3))
        self.stack: list[tuple[str, _State]] = []
        self.named: dict[str, Material] = {}
        self.textures: dict[str, tuple] = {}  # name -> (class, kind, ParamSet)
        self.texture_files = TextureLibrary(self.scene)
        self.coord_systems: dict[str, np.ndarray] = {}
        self.camera_from_world: np.ndarray | None = None
        self.camera_params: ParamSet | None = None
        self.material_ids: dict = {}
        self.warned: set[str] = set()
        self.including: list[Path] = []  # the Include chain, to refuse cycles
        self.include_budget = IncludeBudget()  # inclusions and bytes, all files together
        self.placements = 0  # ObjectInstance directives run
        self.camera_statement: Statement | None = None
        # ObjectBegin/End: the object being defined, and each object's prototype meshes
        # (indices into Scene.prototypes) and spheres (placed by every instance)
        self.defining: str | None = None
        self.objects: dict[str, tuple[list[int], list]] = {}

    # dispatch
    def run(self, path: Path, included_at: Statement | None = None):
        where = (included_at.path, included_at.line) if included_at else (path, None)
        if _resolved(path, where) in self.including:
            raise SceneError(f"Include cycle: {path} includes itself", *where)
        if not path.is_file():
            raise SceneError(f"included file not found: {path}", *where)
        if included_at is not None:
            self.include_budget.add(path, where)
        self.including.append(path.resolve())
        text = path.read_text(encoding="utf-8", errors="replace").removeprefix("\ufeff")  # a byte order mark
        self._count_placements(text, path)
        for st in statements(tokenize(text, path), path):
            handler = getattr(self, "do_" + st.name, None)
            if st.name in IGNORED:
                continue
            if handler is None:
                if st.name not in self.warned:
                    self.warned.add(st.name)
                    warn_at(st.path, st.line, f"unknown or unsupported directive "
                            f"'{st.name}'; ignored")
                continue
            try:
                handler(st)
            except (LiftError, RecursionError, MemoryError):
                raise
            except Exception as exc:  # unforeseen: one line naming the directive, marked a bug
                raise internal_error(exc, st.path, st.line) from exc
        self.including.pop()

    def _count_placements(self, text: str, path: Path) -> None:
        """Refuse a file whose ObjectInstance directives, with those run before it, pass
        MAX_INSTANCES before it is parsed (200,000 of them take minutes to parse);
        do_ObjectInstance counts the instances themselves."""
        if self.placements + text.count("ObjectInstance") <= MAX_INSTANCES:  # an upper bound
            return
        placements = self.placements
        for m in _PLACEMENT.finditer(text):
            placements += m.group() == "ObjectInstance"
            if placements > MAX_INSTANCES:
                check_instance_count(placements, (path, text.count("\n", 0, m.start()) + 1))

    def _positional(self, st: Statement, count: int, kind=float) -> list:
        """The first `count` arguments, as pbrt writes them: bare or in one bracket."""
        args = st.args
        if len(args) >= 1 and isinstance(args[0], list) and count > 1:
            args = args[0] + args[1:]
        vals = args[:count]
        if len(vals) < count or not all(isinstance(v, kind) for v in vals):
            raise SceneError(f"{st.name} needs {count} "
                             f"{'numbers' if kind is float else 'string'}", st.path, st.line)
        return vals

    def _params(self, st: Statement, skip: int) -> ParamSet:
        return ParamSet.parse(st.args[skip:], st)

    def _kind_and_params(self, st: Statement):
        kind = self._positional(st, 1, str)[0]
        return kind, self._params(st, 1)

    # transforms
    def _concat(self, m):
        self.state.ctm = self.state.ctm @ m

    def do_Identity(self, st):
        self.state.ctm = np.eye(4)

    def do_Translate(self, st):
        self._concat(prim.translate_matrix(self._positional(st, 3)))

    def do_Scale(self, st):
        self._concat(prim.scale_matrix(self._positional(st, 3)))

    def do_Rotate(self, st):
        angle, *axis = self._positional(st, 4)
        if not np.linalg.norm(axis) > 0:
            raise SceneError("Rotate: the axis is zero", st.path, st.line)
        self._concat(prim.axis_angle_matrix(angle, axis))

    def do_LookAt(self, st):
        v = np.asarray(self._positional(st, 9))
        eye, look, up = v[:3], v[3:6], v[6:]
        d = look - eye
        right = np.cross(up / np.linalg.norm(up), d / np.linalg.norm(d))
        if np.linalg.norm(d) == 0 or np.linalg.norm(right) == 0:
            raise SceneError("LookAt: eye equals target, or up is parallel to the view",
                             st.path, st.line)
        d /= np.linalg.norm(d)
        right /= np.linalg.norm(right)
        world_from_camera = np.eye(4)
        world_from_camera[:3, 0], world_from_camera[:3, 1] = right, np.cross(d, right)
        world_from_camera[:3, 2], world_from_camera[:3, 3] = d, eye
        self._concat(np.linalg.inv(world_from_camera))

    def _matrix(self, st):
        # pbrt lists the matrix column by column.
        m = np.asarray(self._positional(st, 16)).reshape(4, 4).T
        problem = affine_problem(m)
        if problem:
            raise SceneError(f"{st.name}: {problem}", st.path, st.line)
        return m

    def do_Transform(self, st):
        self.state.ctm = self._matrix(st)

    def do_ConcatTransform(self, st):
        self._concat(self._matrix(st))

    def do_CoordinateSystem(self, st):
        self.coord_systems[self._positional(st, 1, str)[0]] = self.state.ctm.copy()

    def do_CoordSysTransform(self, st):
        name = self._positional(st, 1, str)[0]
        if name not in self.coord_systems:
            warn_at(st.path, st.line, f"unknown coordinate system '{name}'; ignored")
        else:
            self.state.ctm = self.coord_systems[name].copy()

    def do_ReverseOrientation(self, st):
        self.state.reverse = not self.state.reverse

    # blocks
    def _push(self, kind):
        self.stack.append((kind, replace(self.state, ctm=self.state.ctm.copy())))

    def _pop(self, kind, st):
        if not self.stack or self.stack[-1][0] != kind:
            raise SceneError(f"{kind}End without a matching {kind}Begin", st.path, st.line)
        saved = self.stack.pop()[1]
        if kind == "Transform":
            self.state.ctm = saved.ctm
        else:
            self.state = saved

    def do_AttributeBegin(self, st):
        self._push("Attribute")

    def do_AttributeEnd(self, st):
        self._pop("Attribute", st)

    def do_TransformBegin(self, st):
        self._push("Transform")

    def do_TransformEnd(self, st):
        self._pop("Transform", st)

    # instancing: an object's shapes are defined once (in the space of the transform current
    # inside ObjectBegin) and placed by each ObjectInstance's transform (lift_gl/scene/instances.py)
    def do_ObjectBegin(self, st):
        name = self._positional(st, 1, str)[0]
        if self.defining is not None:
            raise SceneError(f"ObjectBegin '{name}' inside ObjectBegin '{self.defining}' (objects do not nest)",
                             st.path, st.line)
        self._push("Attribute")
        self.defining = name
        self.objects[name] = ([], [])

    def do_ObjectEnd(self, st):
        if self.defining is None:
            raise SceneError("ObjectEnd without a matching ObjectBegin", st.path, st.line)
        self._pop("Attribute", st)
        self.defining = None

    def do_ObjectInstance(self, st):
        name = self._positional(st, 1, str)[0]
        if self.defining is not None:
            raise SceneError(f"ObjectInstance '{name}' inside ObjectBegin '{self.defining}' (instances do not nest)",
                             st.path, st.line)
        if name not in self.objects:
            known = ", ".join(sorted(self.objects)) or "none defined"
            raise SceneError(f"ObjectInstance of unknown object '{name}' (objects: {known})", st.path, st.line)
        m = self.state.ctm
        if not (np.isfinite(m).all() and abs(np.linalg.det(m[:3, :3])) > 1e-300):
            raise SceneError(f"ObjectInstance '{name}': the current transform is singular or not finite "
                             "(a zero Scale?)", st.path, st.line)
        meshes, spheres = self.objects[name]
        self.placements += 1
        check_instance_count(max(self.placements, len(self.scene.instances) + len(meshes)), (st.path, st.line))
        for k in meshes:
            self.scene.instances.append(Instance(k, m.copy(), name=name, source=f"{st.path}:{st.line}"))
        for sphere in spheres:
            self.scene.spheres.append(prim.transform_sphere(sphere, m))

    def do_WorldBegin(self, st):
        self.coord_systems["world"] = np.eye(4)
        self.state.ctm = np.eye(4)

    # options
    def do_Integrator(self, st):
        kind, ps = self._kind_and_params(st)
        self.scene.max_depth = ps.int("maxdepth", 5)  # pbrt-v3's default
        if kind not in ("path", "volpath", "bdpt"):
            warn_at(st.path, st.line, f"Integrator '{kind}': only its maxdepth is used")
        ps.warn_unused(f"Integrator '{kind}'")

    def do_PixelFilter(self, st):
        kind, ps = self._kind_and_params(st)
        default_width = {"box": 0.5, "triangle": 2.0, "gaussian": 2.0}  # pbrt-v3's defaults
        if kind not in default_width:
            warn_at(st.path, st.line, f"PixelFilter '{kind}' has negative lobes, which cannot be sampled as a "
                                      "density; using a box over each pixel")
            self.scene.pixel_filter = None
            return
        radius = (ps.float("xwidth", default_width[kind]), ps.float("ywidth", default_width[kind]))
        alpha = ps.float("alpha", 2.0) if kind == "gaussian" else 2.0
        ps.warn_unused(f"PixelFilter '{kind}'")
        if not all(np.isfinite(r) and r > 0 for r in radius) or not alpha > 0:
            raise SceneError(f"PixelFilter '{kind}': xwidth, ywidth and alpha must be positive", st.path, st.line)
        self.scene.pixel_filter = film_filter(kind, radius, alpha, source=f"{st.path}:{st.line}")

    def do_Film(self, st):
        kind, ps = self._kind_and_params(st)
        self.scene.film_size = (ps.int("xresolution", 1280), ps.int("yresolution", 720))
        if min(self.scene.film_size) <= 0:
            raise SceneError(f"Film '{kind}': xresolution and yresolution must be positive, got "
                             f"{self.scene.film_size[0]} x {self.scene.film_size[1]}", st.path, st.line)
        ps.warn_unused(f"Film '{kind}'", ignore=("filename",))

    def do_Camera(self, st):
        kind, ps = self._kind_and_params(st)
        if kind != "perspective":
            warn_at(st.path, st.line, f"camera '{kind}' is not supported; using perspective")
        self.camera_from_world = self.state.ctm.copy()
        self.camera_statement = st
        m = self.camera_from_world
        if not (np.isfinite(m).all() and abs(np.linalg.det(m)) > 1e-300):
            raise SceneError("the camera's transform is singular or not finite (a zero Scale?)",
                             st.path, st.line)
        self.coord_systems["camera"] = np.linalg.inv(self.camera_from_world)
        self.camera_params = ps

    def _finish_camera(self):
        ps = self.camera_params or ParamSet()
        m = self.camera_from_world if self.camera_from_world is not None else np.eye(4)
        st = self.camera_statement
        if not (np.isfinite(m).all() and abs(np.linalg.det(m[:3, :3])) > 1e-300):
            raise SceneError("the camera's transform is singular or not finite (a zero Scale?)",
                             *((st.path, st.line) if st else (self.root, None)))
        world_from_camera = np.linalg.inv(m)
        position = world_from_camera[:3, 3]
        right, up, forward = (world_from_camera[:3, i] for i in range(3))
        forward = forward / np.linalg.norm(forward)
        w, h = self.scene.film_size
        fov = ps.float("fov", 90.0)
        if w < h:  # pbrt's fov spans the shorter axis; ours is vertical
            fov = float(np.degrees(2 * np.arctan(np.tan(np.radians(fov) / 2) * h / w)))
        lens = ps.float("lensradius", 0.0)
        focus = ps.float("focaldistance", 1e6)
        ps.warn_unused("Camera")
        self.scene.camera = Camera(position=position, target=position + forward, up=up,
                                   fov_deg=fov, aperture_radius=lens,
                                   focus_distance=focus if lens > 0 else None)
        # pbrt's image x is camera +x; ours is cross(forward, up). Mirror the world if the
        # two disagree, so that what pbrt shows on the left stays on the left.
        if np.dot(np.cross(forward, up), right) < 0:
            self._mirror_world()

    def _mirror_world(self):
        prim.mirror_scene_x(self.scene)

    # materials and lights
    def do_MakeNamedMaterial(self, st):
        name, ps = self._kind_and_params(st)
        kind = ps.string("type")
        if kind is None:
            raise SceneError(f"MakeNamedMaterial '{name}' has no \"string type\"",
                             st.path, st.line)
        self.named[name] = make_material(kind, ps, name, self._colour)

    def do_NamedMaterial(self, st):
        name = self._positional(st, 1, str)[0]
        if name not in self.named:
            raise SceneError(f"unknown named material '{name}'", st.path, st.line)
        self.state.material = self.named[name]

    def do_Material(self, st):
        kind, ps = self._kind_and_params(st)
        self.state.material = make_material(kind, ps, f"{kind}@{st.line}", self._colour)

    # textures
    def do_Texture(self, st):
        if len(st.args) < 3 or not all(isinstance(a, str) for a in st.args[:3]):
            raise SceneError('Texture needs "name" "type" "class"', st.path, st.line)
        name, value_type, kind = st.args[:3]
        self.textures[name] = (value_type, kind, self._params(st, 3))

    def _colour(self, ps: ParamSet, param: str, default):
        """(rgb, texture index or None) of a parameter that may name a texture."""
        p = ps.params.get(param)
        if p is None or p.type != "texture":
            return ps.spectrum(param, default), None
        ps.used.add(param)
        name = p.values[0] if p.values else None
        if name not in self.textures:
            warn_at(*ps.where, f"parameter '{param}': unknown texture {name!r}; using "
                    f"{np.round(default, 3).tolist()}")
            return np.asarray(default, dtype=np.float64), None
        return self._texture(name, default)

    def _texture(self, name: str, default):
        value_type, kind, tps = self.textures[name]
        where = tps.where
        if kind == "constant":
            return tps.spectrum("value", default), None
        if kind == "scale":
            a, ta = self._texture_operand(tps, "tex1", default)
            b, tb = self._texture_operand(tps, "tex2", [1, 1, 1])
            if ta is not None and tb is not None:
                warn_at(*where, f"texture '{name}': the product of two image textures is not "
                        "supported; using the first")
            return a * b, ta if ta is not None else tb
        if kind != "imagemap":
            key = f"texture-{kind}"
            if key not in self.warned:
                self.warned.add(key)
                warn_at(*where, f"texture '{name}': '{kind}' textures are not supported; "
                        f"using {np.round(default, 3).tolist()}")
            tps.used.update(tps.params)
            return np.asarray(default, dtype=np.float64), None
        filename = tps.string("filename")
        if filename is None:
            raise SceneError(f"imagemap texture '{name}' needs \"string filename\"", *where)
        path = self.root.parent / filename
        srgb = tps.bool("gamma", path.suffix.lower() not in FLOAT_EXTENSIONS)
        scale = tps.float("scale", 1.0)
        if tps.bool("invert", False):
            warn_at(*where, f"texture '{name}': invert is not supported; ignored")
        if (tps.float("uscale", 1.0), tps.float("vscale", 1.0), tps.float("udelta", 0.0),
                tps.float("vdelta", 0.0)) != (1.0, 1.0, 0.0, 0.0):
            warn_at(*where, f"texture '{name}': uscale/vscale/udelta/vdelta are not "
                    "supported; ignored")
        if tps.string("mapping", "uv") != "uv" or tps.string("wrap", "repeat") != "repeat":
            warn_at(*where, f"texture '{name}': only uv mapping with repeat wrapping is "
                    "supported")
        # Filtering: lift-gl filters bilinearly and antialiases by accumulating jittered
        # samples; pbrt's trilinear / EWA choices do not apply.
        tps.used.update({"trilinear", "maxanisotropy", "filter"})
        tps.warn_unused(f"texture '{name}'")
        index = self.texture_files.load(path, srgb, where)
        if index is None:
            return np.asarray(default, dtype=np.float64), None
        return np.full(3, scale), index

    def _texture_operand(self, tps: ParamSet, param: str, default):
        p = tps.params.get(param)
        if p is not None and p.type == "texture":
            tps.used.add(param)
            name = p.values[0] if p.values else None
            if name in self.textures:
                return self._texture(name, default)
            warn_at(*tps.where, f"parameter '{param}': unknown texture {name!r}")
        return tps.spectrum(param, default), None

    def do_AreaLightSource(self, st):
        kind, ps = self._kind_and_params(st)
        if kind != "diffuse":
            warn_at(st.path, st.line, f"area light '{kind}' is not supported; ignored")
            return
        if ps.bool("twosided", False):
            warn_at(st.path, st.line, "two-sided area lights are not supported; the light "
                    "emits from its front side only")
        self.state.emission = ps.spectrum("L", [1, 1, 1]) * ps.spectrum("scale", [1, 1, 1])
        self.state.emission_source = f"{st.path}:{st.line}"
        ps.warn_unused("AreaLightSource")

    def do_LightSource(self, st):
        kind, ps = self._kind_and_params(st)
        scale = ps.spectrum("scale", [1, 1, 1])
        linear = self.state.ctm[:3, :3]
        if kind == "infinite":
            if self.scene.environment is not None:
                warn_at(st.path, st.line, "a second infinite light replaces the first")
            radiance = ps.spectrum("L", [1, 1, 1]) * scale
            mapname = ps.string("mapname")
            image = None
            if mapname is not None:
                image = read_environment_image_at(self.root.parent / mapname, st)
            self.scene.environment = Environment(radiance, image=image, to_world=linear @ PBRT_TO_MAP.T,
                                                 source=f"{st.path}:{st.line}",
                                                 image_file=str(self.root.parent / mapname) if mapname else "")
            ps.warn_unused("LightSource 'infinite'", ignore=("samples", "nsamples"))
        elif kind == "distant":
            source, target = ps.floats("from", 3, ("point",)), ps.floats("to", 3, ("point",))
            source = np.zeros(3) if source is None else source[0]
            target = np.array([0.0, 0.0, 1.0]) if target is None else target[0]
            direction = linear @ (source - target)  # towards the light
            if not np.linalg.norm(direction) > 0:
                raise SceneError("distant light: 'from' equals 'to'", st.path, st.line)
            self.scene.distant_lights.append(DistantLight(direction, ps.spectrum("L", [1, 1, 1]) * scale,
                                                          source=f"{st.path}:{st.line}"))
            ps.warn_unused("LightSource 'distant'")
        else:
            warn_at(st.path, st.line, f"light source '{kind}' is not supported yet; ignored")

    def _material_index(self) -> int:
        base, emission = self.state.material, self.state.emission
        # Any emission but zero, so that a negative one reaches validate_scene, which refuses it.
        emissive = emission is not None and bool(np.any(emission != 0))
        key = (id(base), tuple(emission) if emissive else None)
        if key not in self.material_ids:
            m = base
            if emissive:  # its own copy, so other shapes with this material don't glow
                m = replace(base, name=f"{base.name}+light{len(self.material_ids)}",
                            emission=np.asarray(emission, dtype=np.float64), source=self.state.emission_source)
            self.scene.materials.append(m)
            self.material_ids[key] = len(self.scene.materials) - 1
        return self.material_ids[key]

    # shapes
    def do_Shape(self, st):
        kind, ps = self._kind_and_params(st)
        m = self.state.ctm
        if not (np.isfinite(m).all() and abs(np.linalg.det(m[:3, :3])) > 1e-300):
            raise SceneError(f"Shape '{kind}': the current transform is singular or not finite "
                             "(a zero Scale?)", st.path, st.line)
        src = f"{st.path}:{st.line}"
        if kind == "sphere":
            self._sphere(st, ps, src)
        elif kind in ("trianglemesh", "plymesh"):
            mesh = self._trianglemesh(st, ps) if kind == "trianglemesh" else self._plymesh(st, ps)
            mesh.material, mesh.source = self._material_index(), src
            mesh = prim.orient_to_normals(prim.transform_mesh(mesh, self.state.ctm, flip=self.state.reverse))
            if self.defining is not None:  # a prototype, in the object's space
                self.scene.prototypes.append(mesh)
                self.objects[self.defining][0].append(len(self.scene.prototypes) - 1)
            else:
                self.scene.meshes.append(mesh)
        else:
            warn_at(st.path, st.line, f"shape '{kind}' is not supported yet; ignored")
            return
        ps.warn_unused(f"Shape '{kind}'")

    def _trianglemesh(self, st, ps) -> Mesh:
        p = ps.floats("P", 3, ("point",))
        if p is None:
            raise SceneError("trianglemesh needs \"point P\"", st.path, st.line)
        idx = ps.ints("indices")
        if idx is None and len(p) == 3:
            idx = np.arange(3)
        if idx is None or len(idx) % 3:
            raise SceneError("trianglemesh needs \"integer indices\", a multiple of 3",
                             st.path, st.line)
        if len(idx) and (idx.min() < 0 or idx.max() >= len(p)):
            raise SceneError(f"trianglemesh index out of range (0..{len(p) - 1})",
                             st.path, st.line)
        n = ps.floats("N", 3, ("normal",))
        uv = ps.floats("uv", 2, ("float", "point2")) if "uv" in ps.params else \
            ps.floats("st", 2, ("float", "point2"))
        for name, arr in (("N", n), ("uv", uv)):
            if arr is not None and len(arr) != len(p):
                raise SceneError(f"trianglemesh '{name}' has {len(arr)} entries for "
                                 f"{len(p)} points", st.path, st.line)
        return Mesh("trianglemesh", p, idx.reshape(-1, 3), 0, normals=n, uvs=uv)

    def _plymesh(self, st, ps) -> Mesh:
        file = ps.string("filename")
        if file is None:
            raise SceneError("plymesh needs \"string filename\"", st.path, st.line)
        return load_mesh_file(self.root.parent / file, ref=(st.path, st.line))

    def _sphere(self, st, ps, src):
        radius = ps.float("radius", 1.0)
        if not 0 < radius < float("inf"):
            raise SceneError(f"sphere \"float radius\" must be positive and finite, got {radius}",
                             st.path, st.line)
        if ps.float("zmin", -radius) > -radius or ps.float("zmax", radius) < radius \
                or ps.float("phimax", 360.0) < 360.0:
            warn_at(st.path, st.line, "partial spheres (zmin/zmax/phimax) are not "
                    "supported; rendering the whole sphere")
        if not prim.uniform_scale(self.state.ctm):
            warn_at(st.path, st.line, "a sphere under non-uniform scale is not supported; "
                    "using the mean scale")
        if self.state.reverse and self.state.emission is not None:
            warn_at(st.path, st.line, "ReverseOrientation on an emitting sphere is not "
                    "supported; it emits outwards")
        s = prim.sphere([0, 0, 0], radius, self._material_index(), src)
        s = prim.transform_sphere(s, self.state.ctm)
        if self.defining is not None:  # spheres are exact, not triangles: each instance gets a copy
            self.objects[self.defining][1].append(s)
        else:
            self.scene.spheres.append(s)

    # files
    def do_Include(self, st):
        self.run(self.root.parent / self._positional(st, 1, str)[0], included_at=st)

    do_Import = do_Include


def _resolved(path: Path, where) -> Path:
    """The file an Include names, with symbolic links followed; a link loop is refused."""
    try:
        return path.resolve(strict=False)
    except (RuntimeError, OSError) as e:  # Python raises RuntimeError for a symlink loop
        raise SceneError(f"cannot follow the include {path} ({e})", *where) from None


def read_environment_image_at(path: Path, st: Statement) -> np.ndarray:
    """The map, with errors pointing at the directive (and naming the map file)."""
    try:
        return read_environment_image(path)
    except SceneError as e:
        raise SceneError(f"{e.message}: {path}", st.path, st.line) from None


def load_pbrt(path: Path) -> Scene:
    b = _Builder(Path(path))
    b.run(Path(path))
    b._finish_camera()
    return b.scene
