"""Mitsuba BSDFs and textures as lift-gl materials.

| Mitsuba | lift-gl |
| --- | --- |
| diffuse (reflectance: rgb or bitmap) | diffuse |
| conductor, roughconductor (material / eta, k; specular_reflectance; alpha) | conductor; material "none" is a perfect mirror |
| dielectric, roughdielectric (int_ior / ext_ior, numbers or names) | dielectric, ior = int / ext |
| plastic, roughplastic (diffuse_reflectance, int_ior, nonlinear, alpha) | plastic |
| twosided | its BSDF (lift-gl's opaque surfaces reflect on both sides anyway) |
| mask, bumpmap, normalmap, blendbsdf, thindielectric, roughdiffuse | approximated, with a warning |

Roughness: alpha (or the geometric mean of alpha_u and alpha_v, with a warning). Rough
conductors keep their distribution (GGX or Beckmann, Mitsuba's default); rough glass and
plastic are GGX, a Beckmann one approximated by GGX of the same alpha, with a warning. Bitmaps: sRGB-decoded unless raw; bilinear, repeating.
"""
from __future__ import annotations

import numpy as np

from ..errors import SceneError
from .mitsuba_props import Props, parse_color
from .model import Material
from .toml_loader import METALS
from .xml_tree import Node

# Mitsuba's named indices of refraction (its documentation's table).
IOR = {
    "vacuum": 1.0, "helium": 1.00004, "hydrogen": 1.00013, "air": 1.000277, "carbon dioxide": 1.00045,
    "water": 1.3330, "acetone": 1.36, "ethanol": 1.361, "carbon tetrachloride": 1.461,
    "glycerol": 1.4729, "benzene": 1.501, "silicone oil": 1.52045, "bromine": 1.661,
    "water ice": 1.31, "fused quartz": 1.458, "pyrex": 1.470, "acrylic glass": 1.49,
    "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544, "amber": 1.55,
    "pet": 1.575, "diamond": 2.419,
}
# Mitsuba's conductor presets that lift-gl has RGB indices for (toml_loader.METALS).
METAL_NAMES = {"au": "gold", "ag": "silver", "cu": "copper", "al": "aluminium", "cr": "chrome"}

WRAPPERS = {"twosided", "mask", "bumpmap", "normalmap"}


class BsdfReader:
    """`ctx` is the loader: ctx.warn(node, message, key=None), ctx.lookup(id, node) -> Node,
    ctx.texture_files (TextureLibrary), ctx.folder, ctx.version (major version)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.cache: dict[int, Material | None] = {}

    def material(self, node: Node, name: str) -> Material | None:
        """None for Mitsuba's 'null' BSDF (an invisible surface)."""
        if id(node) not in self.cache:
            self.cache[id(node)] = self._material(node, name)
        return self.cache[id(node)]

    # ---- helpers ---------------------------------------------------------------------------
    def _inner(self, node: Node) -> Node | None:
        inner = [c for c in node.children if c.tag == "bsdf" or (c.tag == "ref" and c.get("name") in (None, "bsdf"))]
        if not inner:
            return None
        if len(inner) > 1 and node.get("type") == "twosided":
            self.ctx.warn(node, "twosided with two different BSDFs: the front one is used on both sides")
        first = inner[0]
        return self.ctx.lookup(first.get("id"), first) if first.tag == "ref" else first

    def _alpha(self, p: Props, beckmann_ok: bool = False) -> tuple[float, str]:
        """(alpha, distribution); Beckmann is kept where lift-gl has it (conductors)."""
        alpha = p.float("alpha", None)
        au, av = p.float("alpha_u", None), p.float("alpha_v", None)
        if alpha is None and au is not None:
            alpha = float(np.sqrt(au * (av if av is not None else au)))
            if av is not None and abs(au - av) > 1e-6:
                self.ctx.warn(p.node, "anisotropic roughness is approximated by the geometric mean of alpha_u "
                              "and alpha_v", key=("anisotropic",))
        if alpha is None:
            alpha = 0.1
        distribution = p.string("distribution", "beckmann").lower()
        if distribution not in ("ggx", "beckmann"):
            raise SceneError(f"unknown microfacet distribution '{distribution}' (ggx, beckmann)",
                             *p.items["distribution"].where)
        if distribution == "beckmann" and not beckmann_ok:
            self.ctx.warn(p.node, f"beckmann microfacets are approximated by GGX of the same alpha for "
                          f"{p.kind}", key=("distribution", p.kind))
            distribution = "ggx"
        p.used.update({"sample_visible"})
        return alpha, distribution

    def _ior(self, p: Props, name: str, default: str) -> float:
        node = p.items.get(name)
        if node is None:
            return IOR[default]
        p.used.add(name)
        if node.tag == "string":
            key = node.get("value", "").strip().lower()
            if key not in IOR:
                raise SceneError(f"unknown index of refraction '{node.get('value')}' (known: "
                                 f"{', '.join(sorted(IOR))})", *node.where)
            return IOR[key]
        value = p.float(name)
        if not value > 0:
            raise SceneError(f"'{name}' must be positive", *node.where)
        return value

    def colour(self, p: Props, name: str, default) -> tuple[np.ndarray, int | None]:
        """(rgb, texture index or None): an <rgb>/<spectrum>, a <texture>, or a <ref> to one."""
        node = p.color_node(name)
        if node is None:
            return np.asarray(default, dtype=np.float64), None
        if node.tag == "ref":
            node = self.ctx.lookup(node.get("id"), node)
            if node.tag != "texture":
                raise SceneError(f"'{name}' refers to a <{node.tag}>, not a texture", *node.where)
        if node.tag != "texture":
            return parse_color(node, self.ctx.warn), None
        return self._texture(node, default)

    def _texture(self, node: Node, default) -> tuple[np.ndarray, int | None]:
        t = Props(node, self.ctx.warn)
        if t.kind == "checkerboard":
            a, _ = self.colour(t, "color0", [0.4] * 3)
            b, _ = self.colour(t, "color1", [0.2] * 3)
            self.ctx.warn(node, "checkerboard textures are approximated by their mean colour",
                          key=("texture", "checkerboard"))
            t.transform("to_uv")
            t.warn_unused()
            return 0.5 * (a + b), None
        if t.kind != "bitmap":
            self.ctx.warn(node, f"texture '{t.kind}' is not supported; using {np.round(default, 3).tolist()}",
                          key=("texture", t.kind))
            return np.asarray(default, dtype=np.float64), None
        filename = t.string("filename")
        if filename is None:
            raise SceneError("bitmap texture needs a 'filename'", *node.where)
        raw = t.bool("raw", False)
        gamma = t.float("gamma", None)  # Mitsuba 0.5: 1 means linear data
        if gamma is not None and abs(gamma - 1.0) < 1e-6:
            raw = True
        if t.string("wrap_mode", "repeat").lower() != "repeat" or \
                t.string("wrap_mode_u", "repeat").lower() != "repeat" or \
                t.string("wrap_mode_v", "repeat").lower() != "repeat":
            self.ctx.warn(node, "only repeating textures are supported", key=("wrap",))
        if t.has("to_uv") and not np.allclose(t.transform("to_uv"), np.eye(4)):
            self.ctx.warn(node, "texture coordinate transforms (to_uv) are not supported; ignored")
        for k in ("uscale", "vscale", "uoffset", "voffset"):
            if t.float(k, 1.0 if "scale" in k else 0.0) != (1.0 if "scale" in k else 0.0):
                self.ctx.warn(node, f"'{k}' is not supported; ignored")
        # Filtering: lift-gl interpolates bilinearly and antialiases by accumulating jittered
        # samples, whatever the file asks.
        t.used.update({"filter_type", "max_anisotropy", "cache", "format", "channel"})
        t.warn_unused()
        index = self.ctx.texture_files.load(self.ctx.folder / filename, srgb=not raw, where=node.where)
        if index is None:
            return np.asarray(default, dtype=np.float64), None
        return np.ones(3), index

    # ---- the BSDFs -------------------------------------------------------------------------
    def _material(self, node: Node, name: str) -> Material | None:
        kind = node.get("type", "")
        src = f"{node.path}:{node.line}"
        warn = self.ctx.warn
        if kind in WRAPPERS:
            if kind == "mask":
                warn(node, "mask (opacity) BSDFs are not supported: the surface is opaque", key=("mask",))
            elif kind != "twosided":
                warn(node, f"{kind} is not supported: the surface is flat-shaded by its own normals",
                     key=(kind,))
            inner = self._inner(node)
            if inner is None:
                if kind == "twosided":
                    return Material(name, "diffuse", base_color=[0.5] * 3, source=src)
                raise SceneError(f"{kind} BSDF without a nested BSDF", *node.where)
            return self.material(inner, name)
        if kind == "blendbsdf":
            warn(node, "blendbsdf is approximated by its first BSDF", key=("blendbsdf",))
            inner = self._inner(node)
            return self.material(inner, name) if inner is not None else Material(name, source=src)
        if kind == "null":
            return None

        p = Props(node, warn)
        if kind in ("diffuse", "roughdiffuse"):
            if kind == "roughdiffuse":
                warn(node, "roughdiffuse is approximated by a Lambertian diffuse", key=("roughdiffuse",))
                p.used.update({"alpha", "use_fast_approx", "distribution"})
            rgb, tex = self.colour(p, "reflectance", [0.5] * 3)
            m = Material(name, "diffuse", base_color=rgb, texture=tex, source=src)
        elif kind in ("conductor", "roughconductor"):
            alpha, distribution = self._alpha(p, beckmann_ok=True) if kind == "roughconductor" else (0.0, "ggx")
            m = Material(name, "conductor", base_color=[1, 1, 1], source=src, alpha=alpha,
                         distribution=distribution)
            tint, tex = self.colour(p, "specular_reflectance", [1, 1, 1])
            if tex is not None:
                warn(node, "textured specular_reflectance is not supported; using 1")
            preset = p.string("material", "cu" if self.ctx.version < 2 else "none")
            if p.has("eta") or p.has("k"):
                eta, _ = self.colour(p, "eta", [0.0] * 3)
                k, _ = self.colour(p, "k", [0.0] * 3)
                m.eta, m.k = eta, k
            elif preset.lower() == "none":  # a perfect mirror
                m.base_color = tint
            elif preset.lower() in METAL_NAMES:
                m.eta, m.k = (np.array(x) for x in METALS[METAL_NAMES[preset.lower()]])
            else:
                warn(node, f"conductor preset '{preset}' is unknown to lift-gl (known: none, "
                     f"{', '.join(sorted(METAL_NAMES))}); using a perfect mirror")
                m.base_color = tint
            if m.eta is not None:
                ext = p.float("ext_eta", 1.0)
                m.eta, m.k, m.specular = m.eta / ext, m.k / ext, tint
        elif kind in ("dielectric", "roughdielectric", "thindielectric"):
            if kind == "thindielectric":
                warn(node, "thindielectric is approximated by a solid dielectric", key=("thindielectric",))
            ior = self._ior(p, "int_ior", "bk7") / self._ior(p, "ext_ior", "air")
            tint, tex = self.colour(p, "specular_transmittance", [1, 1, 1])
            refl, _ = self.colour(p, "specular_reflectance", [1, 1, 1])
            if tex is not None or not np.allclose(refl, 1.0):
                warn(node, "textured transmittance and specular_reflectance other than 1 are not "
                     "supported; ignored", key=("dielectric-tint",))
            m = Material(name, "dielectric", base_color=tint, ior=ior, source=src,
                         alpha=self._alpha(p)[0] if kind == "roughdielectric" else 0.0)
        elif kind in ("plastic", "roughplastic"):
            ior = self._ior(p, "int_ior", "polypropylene") / self._ior(p, "ext_ior", "air")
            rgb, tex = self.colour(p, "diffuse_reflectance", [0.5] * 3)
            spec, spec_tex = self.colour(p, "specular_reflectance", [1, 1, 1])
            if spec_tex is not None:
                warn(node, "textured specular_reflectance is not supported; using 1")
            m = Material(name, "plastic", base_color=rgb, texture=tex, ior=ior, specular=spec,
                         nonlinear=p.bool("nonlinear", False), source=src,
                         alpha=self._alpha(p)[0] if kind == "roughplastic" else 0.0)
        else:
            warn(node, f"BSDF '{kind}' is not supported; approximated as a grey diffuse", key=("bsdf", kind))
            return Material(name, "diffuse", base_color=[0.5] * 3, source=src)
        p.warn_unused()
        return m
