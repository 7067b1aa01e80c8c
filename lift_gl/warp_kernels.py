"""The GPU side of a sampling check (`lift-gl warptest`, the BSDF tests): a sampling routine
run on uniform numbers, and its pdf integrated over the cells of a grid.

A domain is a rectangle of parameters (a, b) with a map to points: (x, y) for the square
and the disk (the disk's cells are those of its bounding square, the pdf taken as 0 outside
the disk), (cos theta, phi) for directions on the sphere and the upper hemisphere, where
d(cos theta) d(phi) is solid angle, so that every cell of the grid has the same area. The
pdf's integral over a cell is Gauss-Legendre in a shader (chi2.adaptive_cell_integrals
refines it), which also reports the least value the pdf took and where it was not finite.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .chi2 import SPHERE_BOUNDS, adaptive_cell_integrals, grid_rects, sphere_coordinates
from .glsl_kernel import ALL_MATERIALS, Kernel

GAUSS_ORDER = 8       # Gauss-Legendre nodes per rectangle and dimension
MAX_ORDER = 16        # the kernel's node arrays
BSDF_GRID = (48, 96)  # (cos theta, phi) cells over the sphere, for BSDFs
BATCH = 1 << 20       # samples per dispatch: bounds the buffers, whatever --samples is
UNIT_TOLERANCE = 1e-4  # | |w| - 1 | beyond which a direction counts as outside the domain
DISK_TOLERANCE = 1e-5  # x^2 + y^2 <= 1 + this counts as inside the disk (float32 rounding)

# The kernel that integrates `density_at(a, b)` over rectangles (a0, a1, b0, b1) of the
# parameters; `domain_b_range(a)` clips b to where the domain is (the disk's chord), so that
# Gauss-Legendre never meets the disk's edge inside a rectangle as a jump.
PDF_KERNEL = """
layout(std430, binding = 10) readonly buffer Rects { vec4 rects[]; };
// Each rectangle's integral, the least pdf at its nodes, and how many nodes were NaN or Inf.
layout(std430, binding = 11) writeonly buffer RectIntegral { vec4 rect_integral[]; };
uniform int u_order;
uniform float u_nodes[16];    // on [-1, 1]
uniform float u_weights[16];
void main() {
    uint r = invocation_index();
    if (r >= u_count) return;
    vec4 rect = rects[r];
    float a_mid = 0.5 * (rect.x + rect.y), a_half = 0.5 * (rect.y - rect.x);
    float total = 0.0, least = 3.0e38, nonfinite = 0.0;
    for (int i = 0; i < u_order; ++i) {
        float a = a_mid + a_half * u_nodes[i];
        vec2 chord = domain_b_range(a);
        float b0 = max(rect.z, chord.x), b1 = min(rect.w, chord.y);
        if (!(b1 > b0)) continue;
        float b_mid = 0.5 * (b0 + b1), b_half = 0.5 * (b1 - b0);
        float row = 0.0;
        for (int j = 0; j < u_order; ++j) {
            float density = density_at(a, b_mid + b_half * u_nodes[j]);
            if (isnan(density) || isinf(density)) { nonfinite += 1.0; continue; }
            least = min(least, density);
            row += u_weights[j] * density;
        }
        total += u_weights[i] * row * b_half;
    }
    rect_integral[r] = vec4(total * a_half, least, nonfinite, 0.0);
}
"""

# density_at(a, b): the pdf at the point of parameters (a, b). Its arguments have long names:
# a parameter would hide a student's function of the same name.
WHOLE_B_AXIS = "vec2 domain_b_range(float a) { return vec2(-3.0e38, 3.0e38); }\n"
DISK_CHORD = "vec2 domain_b_range(float x) { float h = sqrt(max(0.0, 1.0 - x * x)); return vec2(-h, h); }\n"
POINT_DENSITY = """
float density_at(float warptest_x, float warptest_y) { return @PDF@(vec2(warptest_x, warptest_y)); }
"""
DIRECTION_AT = """
vec3 direction_at(float cos_theta, float phi) {
    float c = clamp(cos_theta, -1.0, 1.0), s = sqrt(max(0.0, 1.0 - c * c));
    return vec3(s * cos(phi), s * sin(phi), c);
}
"""
DIRECTION_DENSITY = DIRECTION_AT + """
float density_at(float warptest_c, float warptest_phi) { return @PDF@(direction_at(warptest_c, warptest_phi)); }
"""
BSDF_DENSITY = DIRECTION_AT + """
uniform vec3 u_wo;
float density_at(float warptest_c, float warptest_phi) {
    return @PDF@(test_material(), u_wo, direction_at(warptest_c, warptest_phi));
}
"""


@dataclass(frozen=True)
class Domain:
    name: str
    point_type: str          # what the sampler returns: vec2 (points) or vec3 (directions)
    bounds: tuple            # ((a0, a1), (b0, b1)) of the parameters
    grid: tuple[int, int]    # default cells along a and b
    axes: tuple[str, str]    # the parameters' names, for pictures
    density_glsl: str        # density_at(a, b) and domain_b_range(a), calling @PDF@

    def coordinates(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """Parameters (a, b) of sampled points (N, 4) and, for each way of missing the
        domain ('not finite', 'outside the square', ...), a mask of the samples that do."""
        p = np.asarray(points, dtype=np.float64)
        finite = np.isfinite(p[:, :3]).all(axis=1)
        p = np.where(finite[:, None], p, 0.0)
        misses = {"not finite": ~finite}
        if self.point_type == "vec2":
            a, b = p[:, 0], p[:, 1]
            if self.name == "disk":
                misses["outside the unit disk"] = finite & (a * a + b * b > 1.0 + DISK_TOLERANCE)
            else:
                misses["outside the square"] = finite & ((a < 0) | (a > 1) | (b < 0) | (b > 1))
            return a, b, misses
        length = np.linalg.norm(p[:, :3], axis=1)
        misses["not of unit length"] = finite & (np.abs(length - 1.0) > UNIT_TOLERANCE)
        if self.name == "hemisphere":
            misses["below the horizon (z < 0)"] = finite & (p[:, 2] < 0)
        a, b = sphere_coordinates(p[:, :3] / np.where(length > 0, length, 1.0)[:, None])
        return a, b, misses


DOMAINS = {
    "square": Domain("square", "vec2", ((0.0, 1.0), (0.0, 1.0)), (32, 32), ("x", "y"), WHOLE_B_AXIS + POINT_DENSITY),
    "disk": Domain("disk", "vec2", ((-1.0, 1.0), (-1.0, 1.0)), (32, 32), ("x", "y"), DISK_CHORD + POINT_DENSITY),
    "sphere": Domain("sphere", "vec3", SPHERE_BOUNDS, (32, 64), ("cos theta", "phi"), WHOLE_B_AXIS + DIRECTION_DENSITY),
    "hemisphere": Domain("hemisphere", "vec3", ((0.0, 1.0), SPHERE_BOUNDS[1]), (16, 64), ("cos theta", "phi"),
                         WHOLE_B_AXIS + DIRECTION_DENSITY),
}
# Directions over the whole sphere, for BSDFs: their pdf is a function of wo too.
BSDF_DOMAIN = Domain("sphere", "vec3", SPHERE_BOUNDS, BSDF_GRID, ("cos theta", "phi"), WHOLE_B_AXIS + BSDF_DENSITY)

# Sampling kernels: uniform numbers in (binding 10), points out (binding 11). A BSDF sample's
# w is 0 when the routine rejected it, 1 for a sample with a density, 2 for a delta lobe's.
WARP_SAMPLE_KERNEL = """
layout(std430, binding = 10) readonly buffer UniformNumbers { vec2 u_in[]; };
layout(std430, binding = 11) writeonly buffer Points { vec4 points[]; };
@POINT4@
void main() {  // the names here are long: a local would hide a student's function of its name
    uint warptest_i = invocation_index();
    if (warptest_i >= u_count) return;
    points[warptest_i] = warptest_point4(@SAMPLER@(u_in[warptest_i]));
}
"""
# The one conversion the domain's type has: a sampler of the other type does not compile.
POINT4 = {"vec2": "vec4 warptest_point4(vec2 p) { return vec4(p, 0.0, 0.0); }",
          "vec3": "vec4 warptest_point4(vec3 w) { return vec4(w, 0.0); }"}
BSDF_SAMPLE_KERNEL = """
layout(std430, binding = 10) readonly buffer UniformNumbers { vec4 u_in[]; };
layout(std430, binding = 11) writeonly buffer Points { vec4 points[]; };
uniform vec3 u_wo;
void main() {
    uint warptest_i = invocation_index();
    if (warptest_i >= u_count) return;
    BsdfSample warptest_s;
    bool warptest_ok = @SAMPLER@(test_material(), u_wo, u_in[warptest_i].xyz, warptest_s);
    points[warptest_i] = vec4(warptest_s.wi, warptest_ok ? (warptest_s.is_delta ? 2.0 : 1.0) : 0.0);
}
"""


@dataclass
class CellIntegrals:
    values: np.ndarray       # (na, nb): the pdf's integral over each cell
    error: float             # estimate of the quadrature error of values.sum()
    least: float             # the least value the pdf took at a quadrature node
    least_at: tuple          # the (a, b) of the rectangle where it did
    nonfinite: int           # quadrature nodes where the pdf was NaN or Inf

    @property
    def total(self) -> float:
        return float(self.values.sum())


def cell_integrals(kernel: Kernel, uniforms: dict, bounds, shape, count: int,
                   relative: float | None = None) -> CellIntegrals:
    """The pdf of `kernel` (PDF_KERNEL with a domain's density) integrated over each cell of a
    grid, accurate to well within the noise of `count` samples and, with `relative`, to that
    fraction of each cell's integral (chi2.adaptive_cell_integrals)."""
    nodes, weights = np.polynomial.legendre.leggauss(GAUSS_ORDER)
    pad = np.zeros(MAX_ORDER - GAUSS_ORDER)
    uniforms = {**uniforms, "u_order": GAUSS_ORDER,
                "u_nodes": np.concatenate([nodes, pad]).astype(np.float32),
                "u_weights": np.concatenate([weights, pad]).astype(np.float32)}
    seen = {"least": math.inf, "least_at": (math.nan, math.nan), "nonfinite": 0}

    def integrate(rects: np.ndarray) -> np.ndarray:
        out = kernel.run(len(rects), inputs={10: rects.astype(np.float32)}, outputs={11: (len(rects), 4)},
                         uniforms=uniforms)[11].astype(np.float64)
        k = int(np.argmin(out[:, 1]))
        if out[k, 1] < seen["least"]:
            seen["least"] = float(out[k, 1])
            seen["least_at"] = (0.5 * (rects[k, 0] + rects[k, 1]), 0.5 * (rects[k, 2] + rects[k, 3]))
        seen["nonfinite"] += int(out[:, 2].sum())
        return out[:, 0]

    values, error = adaptive_cell_integrals(integrate, grid_rects(bounds, shape), count, relative=relative)
    return CellIntegrals(values.reshape(shape), error, **seen)


def pdf_kernel(domain: Domain, pdf: str, *, defines=None, include: str = "", library: bool = False,
               name: str = "<warptest kernel>", backend: str = "auto") -> Kernel:
    body = include + domain.density_glsl.replace("@PDF@", pdf) + PDF_KERNEL
    return Kernel(body, defines, library=library, name=name, backend=backend)


def sample_kernel(template: str, sampler: str, *, point_type: str = "vec3", defines=None, include: str = "",
                  library: bool = False, name: str = "<warptest kernel>", backend: str = "auto") -> Kernel:
    """A sampling kernel calling `sampler`; a warp's sampler must return `point_type`."""
    body = template.replace("@SAMPLER@", sampler).replace("@POINT4@", POINT4[point_type])
    return Kernel(include + body, defines, library=library, name=name, backend=backend)


def run_sampler(kernel: Kernel, u: np.ndarray, uniforms: dict | None = None) -> np.ndarray:
    """The sampler of `kernel` on uniform numbers u (N, 2) or (N, 4): points (N, 4), float32,
    in batches of BATCH."""
    out = np.empty((len(u), 4), np.float32)
    for start in range(0, len(u), BATCH):
        part = np.ascontiguousarray(u[start:start + BATCH], dtype=np.float32)
        out[start:start + len(part)] = kernel.run(len(part), inputs={10: part}, outputs={11: (len(part), 4)},
                                                  uniforms=uniforms)[11]
    return out


def bsdf_cell_integrals(mat: np.ndarray, wo, count: int, defines=ALL_MATERIALS, shape=BSDF_GRID) -> np.ndarray:
    """The integral of the library's bsdf_pdf for material `mat` (glsl_kernel.material) and
    outgoing direction wo over each (cos theta, phi) cell of the sphere."""
    kernel = pdf_kernel(BSDF_DOMAIN, "bsdf_pdf", defines=defines, library=True)
    return cell_integrals(kernel, {"u_material": mat, "u_wo": tuple(wo)}, BSDF_DOMAIN.bounds, shape, count).values
