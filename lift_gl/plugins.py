"""Integrator plugins: discovery, manifest validation and parameters.

A plugin is a folder with `plugin.toml` and its shader files. The manifest is the plugin's
documentation and parameter table (`lift-gl plugins` prints it):

    name = "pt"
    description = "Path tracer with next event estimation and MIS"
    language = "glsl"          # or "opencl" (later)
    entry = "pt.glsl"          # defines: vec3 radiance(Ray ray, Hit hit, inout Rng rng)
    primary = "gbuffer"        # first hit from the raster G-buffer, or "camera": traced rays
    splats = false             # optional: true gives the shader splat(pixel_pos, value), which
                               # adds to any pixel of this frame (light tracing, BDPT's t = 1)
    biased = "why"             # optional: the plugin does not converge to the true image, and why
    [params.max_depth]
    type = "int"  default = 16  min = 0  max = 1000  help = "longest path, in bounces"
    define = "MY_MAX_DEPTH"    # optional, int parameters: also a compile-time constant
                               # (#define MY_MAX_DEPTH <value>, e.g. to size arrays);
                               # a new value recompiles the trace pass
    [reduced]                  # optional: a second estimate at reduced resolution, upsampled
    function = "indirect_radiance"  # vec3 indirect_radiance(Ray ray, Hit hit, inout Rng rng)
    scale = "indirect_scale"   # resolution divisor: a number, or the name of an int parameter
    normal_power = 32.0        # joint bilateral upsampling: normal weight max(0, n.n')^power
    depth_sigma = 0.05         # ... and depth weight exp(-|z - z'| / (depth_sigma z))
                               # (both also a number or a parameter's name)
    [prepass]                  # optional: a pass before the trace pass, for every pixel sample
    function = "light_pass"    # void light_pass(ivec2 pixel, inout Rng rng), with the sample's
                               # random numbers; it writes storage the trace pass reads:
    entries = "4 * max_depth + 6"  # uvec4s a pixel sample (prepass_store/prepass_load in
                               # shaders/lift/prepass.glsl): a number, or a formula of int
                               # parameters (+ - * //, min, max)

Plugins are found in the built-in `plugins/` folder, in folders named by `--plugins`, and in
the folders of the `LIFT_GL_PLUGIN_PATH` environment variable (separated by `os.pathsep`).

How the host runs a plugin (the BVH's layout and stack, coherent sampling, ...) is not the
manifest's business: those are the renderer's options (lift_gl/options.py, `--option`). A
manifest that still has the keys of older versions (`bvh_stack`, parameters named
`coherent_sampling` or `coherent_interleave`) loads, with a warning that they do nothing.
"""
from __future__ import annotations

import ast
import math
import operator
import os
import re
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from . import limits
from .errors import PluginError, read_utf8
from .glsl_names import name_conflict

BUILTIN_DIR = Path(__file__).resolve().parent.parent / "plugins"
PARAM_TYPES = {"int": int, "float": float, "bool": bool, "color": list}
GLSL_TYPES = {"int": "int", "float": "float", "bool": "bool", "color": "vec3"}
LANGUAGES = ("glsl", "opencl")
PRIMARY_MODES = ("gbuffer", "camera")
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_MANIFEST_KEYS = {"name", "description", "language", "entry", "primary", "splats", "params", "biased", "reduced",
                  "prepass"}
# Keys and parameters of older manifests that are the host's options now (lift_gl/options.py):
# read past with a warning, never applied.
_RETIRED_KEYS = {"bvh_stack": "bvh_stack_entries"}
_RETIRED_PARAMS = ("coherent_sampling", "coherent_interleave")
_PARAM_KEYS = {"type", "default", "min", "max", "help", "define"}
_REDUCED_KEYS = {"function": None, "scale": "int", "normal_power": "float", "depth_sigma": "float"}
_HOST_DEFINE_PREFIXES = ("HAS_", "LIFT_", "PRIMARY_", "GL_")  # features, host switches, GLSL's own
_PREPASS_KEYS = {"function", "entries"}
REDUCED_DEFAULTS = {"scale": 2, "normal_power": 32.0, "depth_sigma": 0.05}


@dataclass
class Param:
    name: str
    type: str
    default: object
    min: float | None = None
    max: float | None = None
    help: str = ""
    define: str = ""  # int parameters: also `#define <define> <value>` in the trace pass's shader

    def parse(self, text_or_value):
        """A value for this parameter from a string (`--set`) or a Python value, checked."""
        value = text_or_value
        try:
            if isinstance(value, str):
                if self.type == "bool":
                    if value.lower() not in ("1", "0", "true", "false", "on", "off", "yes", "no"):
                        raise ValueError(value)
                    value = value.lower() in ("1", "true", "on", "yes")
                elif self.type == "color":
                    value = [float(x) for x in value.replace(",", " ").split()]
                else:
                    value = PARAM_TYPES[self.type](float(value) if self.type == "float" else int(value))
            elif self.type == "float":
                value = float(value)
            elif self.type == "int":
                if isinstance(value, bool) or int(value) != value:
                    raise ValueError(value)
                value = int(value)
            elif self.type == "bool":
                value = bool(value)
            elif self.type == "color":
                value = [float(x) for x in value]
            if self.type in ("float", "color") and not all(map(math.isfinite, value if self.type == "color" else [value])):
                raise ValueError(value)
        except (TypeError, ValueError, OverflowError):
            raise PluginError(f"parameter {self.name} ({self.type}): bad value {text_or_value!r}") from None
        if self.type == "color" and len(value) != 3:
            raise PluginError(f"parameter {self.name}: a colour needs 3 numbers, got {text_or_value!r}")
        if self.type in ("int", "float"):
            if self.min is not None and value < self.min or self.max is not None and value > self.max:
                raise PluginError(f"parameter {self.name}={value} is outside [{self.min}, {self.max}]")
        return value


@dataclass
class ReducedPass:
    """A plugin's estimate run at 1/scale of the resolution and upsampled (passes/reduced_trace.py,
    passes/upsample.py). Each setting is a number or the name of a parameter."""

    function: str
    scale: object = REDUCED_DEFAULTS["scale"]
    normal_power: object = REDUCED_DEFAULTS["normal_power"]
    depth_sigma: object = REDUCED_DEFAULTS["depth_sigma"]

    def value(self, setting: str, params: dict):
        spec = getattr(self, setting)
        return params[spec] if isinstance(spec, str) else spec


@dataclass
class Prepass:
    """A plugin's pass before its trace pass (passes/prepass.py): `function` runs once per pixel
    sample and writes `entries` uvec4s of storage (a number or a formula of int parameters)
    that the trace pass's radiance() reads."""

    function: str
    entries: object

    def entry_count(self, params: dict) -> int:
        """The uvec4s a pixel sample for these parameter values."""
        return int(self.entries) if isinstance(self.entries, int) else _evaluate(self.entries, params)


_FORMULA_CALLS = {"min": min, "max": max}


def _evaluate(formula: str, values: dict) -> int:
    """An integer formula of parameter names: + - * //, parentheses, min() and max()."""
    def value(node):
        if isinstance(node, ast.Expression):
            return value(node.body)
        if isinstance(node, ast.Constant) and type(node.value) is int:
            return node.value
        if isinstance(node, ast.Name) and node.id in values:
            return int(values[node.id])
        if isinstance(node, ast.BinOp) and type(node.op) in _FORMULA_OPS:
            return _FORMULA_OPS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FORMULA_CALLS \
                and node.args and not node.keywords:
            return _FORMULA_CALLS[node.func.id](*(value(a) for a in node.args))
        raise ValueError(ast.dump(node) if isinstance(node, ast.AST) else repr(node))

    return value(ast.parse(formula, mode="eval"))


_FORMULA_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.FloorDiv: operator.floordiv}


@dataclass
class Plugin:
    name: str
    description: str
    language: str
    entry: str
    primary: str
    folder: Path
    params: dict[str, Param] = field(default_factory=dict)
    splats: bool = False  # the host gives the shader a splat buffer (lift/splat.glsl)
    biased: str = ""  # why the plugin does not converge to the true image ("": it does)
    reduced: ReducedPass | None = None
    prepass: Prepass | None = None

    @property
    def manifest(self) -> Path:
        return self.folder / "plugin.toml"

    @property
    def entry_path(self) -> Path:
        return self.folder / self.entry

    def source_files(self) -> list[Path]:
        """The files whose change should trigger a reload."""
        return sorted(p for p in self.folder.iterdir() if p.suffix in (".glsl", ".cl", ".toml"))

    def defaults(self) -> dict:
        return {name: p.default for name, p in self.params.items()}


class PluginWarning(UserWarning):
    """Something in a manifest was read past; the message names file:line."""


def param_defines(plugin: Plugin, values: dict) -> dict:
    """The compile-time constants of the plugin's parameters that have a `define`, for these
    values: the shader is specialised to them (and recompiled when one changes)."""
    return {p.define: int(values.get(name, p.default)) for name, p in plugin.params.items() if p.define}


def _line_of(text: str, pattern: str) -> int | None:
    for number, line in enumerate(text.splitlines(), start=1):
        if re.search(pattern, line):
            return number
    return None


def load_manifest(folder: Path) -> Plugin:
    path = Path(folder) / "plugin.toml"
    if not path.is_file():
        raise PluginError("plugin.toml not found", path)
    limits.check_settings_file(path)
    text = read_utf8(path, PluginError)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        m = re.search(r"line (\d+)", str(exc))
        line = int(m.group(1)) if m else None
        if line is None and "end of document" in str(exc):  # unclosed at the end: its last line
            line = max(len(text.splitlines()), 1)
        raise PluginError(f"malformed TOML: {exc}", path, line) from None
    except RecursionError:
        raise PluginError("malformed TOML: nested too deeply", path) from None

    def fail(message, key_pattern=None):
        raise PluginError(message, path, _line_of(text, key_pattern) if key_pattern else None)

    def warn(message, key_pattern):
        line = _line_of(text, key_pattern)
        warnings.warn(f"{path}:{line}: {message}" if line else f"{path}: {message}", PluginWarning, stacklevel=3)

    for key in data:
        if key in _RETIRED_KEYS:
            warn(f"{key} is ignored: it is the host's option {_RETIRED_KEYS[key]} now "
                 f"(--option {_RETIRED_KEYS[key]}=...)", rf"^\s*{key}\s*=")
        elif key not in _MANIFEST_KEYS:
            fail(f"unknown key {key!r} (known: {', '.join(sorted(_MANIFEST_KEYS))})", rf"^\s*{re.escape(key)}\s*=")
    for key in ("name", "entry"):
        if not isinstance(data.get(key), str) or not data[key]:
            fail(f"missing or empty string key {key!r}", rf"^\s*{key}\s*=")
    name = data["name"]
    if not _IDENT.match(name):
        fail(f"plugin name {name!r} must be an identifier (letters, digits, _)", r"^\s*name\s*=")
    language = data.get("language", "glsl")
    if not isinstance(language, str) or language not in LANGUAGES:
        fail(f"language {language!r} is not one of {', '.join(LANGUAGES)}", r"^\s*language\s*=")
    primary = data.get("primary", "gbuffer")
    if not isinstance(primary, str) or primary not in PRIMARY_MODES:
        fail(f"primary {primary!r} is not one of {', '.join(PRIMARY_MODES)}", r"^\s*primary\s*=")
    splats = data.get("splats", False)
    if not isinstance(splats, bool):
        fail(f"splats must be true or false, not {splats!r}", r"^\s*splats\s*=")
    if "\0" in data["entry"]:
        fail(f"entry {data['entry']!r} holds a NUL character", r"^\s*entry\s*=")
    try:
        (Path(folder) / data["entry"]).resolve()
    except (RuntimeError, OSError) as e:  # Python raises RuntimeError for a symlink loop
        fail(f"entry {data['entry']!r} cannot be followed ({e})", r"^\s*entry\s*=")
    if not inside(Path(folder) / data["entry"], Path(folder)):
        fail(f"entry {data['entry']!r} is outside the plugin's folder {Path(folder).resolve()}: a plugin's files "
             "must be in its folder", r"^\s*entry\s*=")
    if not (Path(folder) / data["entry"]).is_file():
        fail(f"entry file {data['entry']!r} not found in {folder}", r"^\s*entry\s*=")

    params = {}
    if not isinstance(data.get("params", {}), dict):
        fail("'params' must be tables: write [params.NAME]", r"^\s*params\s*=")
    for pname, spec in (data.get("params") or {}).items():
        header = rf"^\s*\[params\.{re.escape(pname)}\]"
        if pname in _RETIRED_PARAMS:
            warn(f"parameter {pname} no longer switches anything: coherent sampling is the host's option "
                 f"(--option {pname}=...)", header)
        if not _IDENT.match(pname):
            fail(f"parameter name {pname!r} must be an identifier", header)
        conflict = name_conflict(pname)   # it becomes a uniform of this name
        if conflict:
            fail(f"parameter {pname!r} {conflict}; name it otherwise", header)
        if not isinstance(spec, dict):
            fail(f"parameter {pname!r} must be a table", header)
        unknown = set(spec) - _PARAM_KEYS
        if unknown:
            fail(f"parameter {pname!r}: unknown keys {sorted(unknown)}", header)
        ptype = spec.get("type")
        if not isinstance(ptype, str) or ptype not in PARAM_TYPES:
            fail(f"parameter {pname!r}: type must be one of {', '.join(PARAM_TYPES)}", header)
        if "default" not in spec:
            fail(f"parameter {pname!r} has no default", header)
        for key in ("min", "max"):
            if key in spec and (isinstance(spec[key], bool) or not isinstance(spec[key], (int, float))):
                fail(f"parameter {pname!r}: {key} must be a number, not {spec[key]!r}", header)
        if not isinstance(spec.get("help", ""), str):
            fail(f"parameter {pname!r}: help must be a string", header)
        define = spec.get("define", "")
        if "define" in spec:
            if ptype != "int":
                fail(f"parameter {pname!r}: only an int parameter can have a define", header)
            if not isinstance(define, str) or not _IDENT.match(define):
                fail(f"parameter {pname!r}: define must be a preprocessor name (letters, digits, _), "
                     f"not {define!r}", header)
            if define.startswith(_HOST_DEFINE_PREFIXES):
                fail(f"parameter {pname!r}: define {define!r} starts like the host's own defines "
                     f"({', '.join(_HOST_DEFINE_PREFIXES)})", header)
            conflict = name_conflict(define)
            if conflict:
                fail(f"parameter {pname!r}: define {define!r} {conflict}; name it otherwise", header)
            if define in data["params"] or any(p.define == define for p in params.values()):
                fail(f"parameter {pname!r}: define {define!r} is already a parameter or another's define",
                     header)
        param = Param(pname, ptype, None, spec.get("min"), spec.get("max"), spec.get("help", ""), define)
        try:
            param.default = param.parse(spec["default"])
        except PluginError as exc:
            fail(exc.message, header)
        params[pname] = param
    biased = data.get("biased", "")
    if not isinstance(biased, str):
        fail("'biased' must be a string saying why the plugin is biased", r"^\s*biased\s*=")
    if not isinstance(data.get("description", ""), str):
        fail("description must be a string", r"^\s*description\s*=")
    return Plugin(name=name, description=data.get("description", ""), language=language,
                  entry=data["entry"], primary=primary, folder=Path(folder).resolve(), params=params,
                  splats=splats, biased=biased, reduced=_reduced(data, params, primary, language, fail),
                  prepass=_prepass(data, params, language, fail))


def _table(data: dict, key: str, known: list, fail) -> dict | None:
    """The manifest's [key] table (None when absent), refused when it is not a table or names
    a key outside `known`."""
    if key not in data:
        return None
    table = data[key]
    if not isinstance(table, dict):
        fail(f"'{key}' must be a table: [{key}]", rf"^\s*{key}\s*=")
    unknown = set(table) - set(known)
    if unknown:
        fail(f"[{key}]: unknown keys {sorted(unknown)} (known: {', '.join(known)})", rf"^\s*\[{key}\]")
    return table


def _reduced(data: dict, params: dict, primary: str, language: str, fail) -> ReducedPass | None:
    """The [reduced] table: checked against the parameters it names."""
    table = _table(data, "reduced", list(_REDUCED_KEYS), fail)
    if table is None:
        return None
    header = r"^\s*\[reduced\]"
    if primary != "gbuffer":
        fail("[reduced] needs primary = \"gbuffer\" (it is guided by the G-buffer's normals and depth)", header)
    if language != "glsl":
        fail("[reduced] is for GLSL plugins (the reduced pass compiles the plugin's GLSL)", header)
    function = table.get("function")
    if not isinstance(function, str) or not _IDENT.match(function):
        fail("[reduced] needs 'function', the name of a GLSL function vec3 f(Ray, Hit, inout Rng)", header)
    for key, kind in _REDUCED_KEYS.items():
        if kind is None or key not in table:
            continue
        spec = table[key]
        if isinstance(spec, str):
            if spec not in params or params[spec].type != kind:
                fail(f"[reduced] {key} = {spec!r} must name an {kind} parameter", header)
        elif isinstance(spec, bool) or not isinstance(spec, (int, float)) or spec <= 0 \
                or (kind == "int" and not isinstance(spec, int)):
            fail(f"[reduced] {key} must be a positive {kind} or a parameter's name, not {spec!r}", header)
    return ReducedPass(function=function, **{k: table[k] for k in REDUCED_DEFAULTS if k in table})


def _prepass(data: dict, params: dict, language: str, fail) -> Prepass | None:
    """The [prepass] table: a function name and a storage size that evaluates for the defaults."""
    table = _table(data, "prepass", sorted(_PREPASS_KEYS), fail)
    if table is None:
        return None
    header = r"^\s*\[prepass\]"
    if language != "glsl":
        fail("[prepass] is for GLSL plugins (the prepass compiles the plugin's GLSL)", header)
    function = table.get("function")
    if not isinstance(function, str) or not _IDENT.match(function):
        fail("[prepass] needs 'function', the name of a GLSL function void f(ivec2 pixel, inout Rng rng)", header)
    entries = table.get("entries")
    prepass = Prepass(function, entries)
    ints = {name: p.default for name, p in params.items() if p.type == "int"}
    try:
        if isinstance(entries, bool) or not isinstance(entries, (int, str)):
            raise ValueError(entries)
        count = prepass.entry_count(ints)
    except (ValueError, SyntaxError, ZeroDivisionError):
        fail(f"[prepass] entries must be a positive integer or a formula of int parameters "
             f"(+ - * //, min, max), not {entries!r}", header)
    if count <= 0:
        fail(f"[prepass] entries = {entries!r} is {count} for the defaults: it must be positive", header)
    return prepass


def inside(path: Path, folder: Path) -> bool:
    """Whether `path`, links followed, is in `folder` (or below it)."""
    try:
        path.resolve().relative_to(folder.resolve())
    except (ValueError, RuntimeError, OSError):  # elsewhere, or a symlink loop
        return False
    return True


class ShadowedPluginWarning(UserWarning):
    """A plugin that another one of the same name hides (the message names both folders)."""


def search_path(extra_dirs=()) -> list[Path]:
    dirs = [Path(d) for d in extra_dirs]
    env = os.environ.get("LIFT_GL_PLUGIN_PATH", "")
    dirs += [Path(d) for d in env.split(os.pathsep) if d]
    dirs.append(BUILTIN_DIR)
    return dirs


def discover(extra_dirs=(), broken: dict | None = None) -> dict[str, Plugin]:
    """All plugins by name; an earlier folder in the search path wins over a later one.

    A plugin with a bad manifest does not hide the others: its error goes into `broken`
    (keyed by folder name) when a dict is given.
    """
    found: dict[str, Plugin] = {}
    for d in reversed(search_path(extra_dirs)):
        if not d.is_dir():
            continue
        for folder in sorted(d.iterdir()):
            if (folder / "plugin.toml").is_file():
                try:
                    plugin = load_manifest(folder)
                except PluginError as exc:
                    if broken is not None:
                        broken[folder.name] = exc
                    continue
                if plugin.name in found:
                    _warn_shadowed(plugin, found[plugin.name])
                found[plugin.name] = plugin
    return found


def _warn_shadowed(plugin: Plugin, hidden: Plugin) -> None:
    import warnings

    kind = "the built-in" if BUILTIN_DIR in hidden.folder.parents else "the plugin"
    warnings.warn(f"{plugin.manifest}: plugin '{plugin.name}' in {plugin.folder} replaces {kind} '{hidden.name}' "
                  f"in {hidden.folder}", ShadowedPluginWarning, stacklevel=3)


def find_plugin(name: str, extra_dirs=()) -> Plugin:
    """A plugin by name, or by the path of its folder."""
    path = Path(name)
    if (path / "plugin.toml").is_file():
        return load_manifest(path)
    broken: dict[str, PluginError] = {}
    plugins = discover(extra_dirs, broken)
    if name in plugins:
        return plugins[name]
    if name in broken:
        raise broken[name]
    raise PluginError(f"no plugin named {name!r}; found: {', '.join(sorted(plugins)) or 'none'}")
