"""bsdf_eval_pdf (shaders/lift/bsdf.glsl), which next event estimation calls for a light
sample's BSDF value and MIS density in one go, must give what bsdf_eval and bsdf_pdf give
separately, for every material and pair of directions, including directions below the
surface, grazing ones and the dielectric's transmission. The separate calls are the ones the
chi-square tests (test_bsdf_chi2.py, test_plastic_bsdf.py) check against sampling."""
from __future__ import annotations

import numpy as np
import pytest

from lift_gl.glsl_kernel import ALL_MATERIALS, MAT_CONDUCTOR, MAT_DIELECTRIC, MAT_DIFFUSE, Kernel, material
from test_plastic_bsdf import MAT_PLASTIC, PLASTIC, plastic

KERNEL = """
layout(std430, binding = 10) readonly buffer Dirs { vec4 dirs[]; };   // wo.xyz, wi.xyz in pairs
layout(std430, binding = 11) writeonly buffer Apart { vec4 apart[]; };
layout(std430, binding = 12) writeonly buffer Together { vec4 together[]; };
void main() {
    uint i = invocation_index();
    if (i >= u_count) return;
    Material m = test_material();
    vec3 wo = dirs[2u * i].xyz, wi = dirs[2u * i + 1u].xyz;
    apart[i] = vec4(bsdf_eval(m, wo, wi), bsdf_pdf(m, wo, wi));
    float pdf;
    vec3 f = bsdf_eval_pdf(m, wo, wi, pdf);
    together[i] = vec4(f, pdf);
}
"""

DEFINES = {**ALL_MATERIALS, **PLASTIC}
MATERIALS = {
    "diffuse": material(MAT_DIFFUSE, color=(0.8, 0.6, 0.4)),
    "rough conductor": material(MAT_CONDUCTOR, color=(1.0, 0.9, 0.8), alpha=0.3, eta=(0.2, 0.9, 1.1), k=(3.9, 2.4, 2.2)),
    "rough conductor, Schlick": material(MAT_CONDUCTOR, color=(0.9, 0.6, 0.3), alpha=0.02),
    "smooth conductor": material(MAT_CONDUCTOR, alpha=0.0),
    "rough dielectric": material(MAT_DIELECTRIC, color=(0.9, 1.0, 0.95), alpha=0.25, ior=1.5),
    "smooth dielectric": material(MAT_DIELECTRIC, alpha=0.0, ior=1.33),
    "rough plastic": plastic(alpha=0.2),
    "rough plastic, nonlinear": plastic(alpha=0.6, nonlinear=True, tint=(0.5, 0.8, 1.0)),
    "smooth plastic": plastic(alpha=0.0),
}


def direction_pairs(n: int, seed: int = 3) -> np.ndarray:
    """wo, wi pairs over the whole sphere (both hemispheres: transmission and the one-sided
    zeros), with a share of grazing ones (|z| < 1e-3) and of wo = wi."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(2 * n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    grazing = rng.random(2 * n) < 0.1
    d[grazing, 2] *= 1e-3
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pairs = d.reshape(n, 2, 3)
    same = rng.random(n) < 0.05
    pairs[same, 1] = pairs[same, 0]
    return np.concatenate([pairs.reshape(2 * n, 3), np.zeros((2 * n, 1))], axis=1).astype(np.float32)


@pytest.mark.parametrize("name", list(MATERIALS))
def test_eval_pdf_together_equals_apart(name):
    n = 1 << 14
    out = Kernel(KERNEL, DEFINES).run(n, inputs={10: direction_pairs(n)}, outputs={11: (n, 4), 12: (n, 4)},
                                      uniforms={"u_material": MATERIALS[name]})
    apart, together = out[11], out[12]
    assert np.isfinite(apart).all()
    # The same expressions in the same order: equal up to what the compiler may contract
    # differently (fused multiply-adds), a few ulps.
    np.testing.assert_allclose(together, apart, rtol=1e-5, atol=1e-30)
    if name.startswith(("rough", "diffuse")) or name == "smooth plastic":
        assert (apart[:, 3] > 0).mean() > 0.2, "the test pairs must reach the lobes"
    else:
        assert not apart.any(), "delta lobes: neither eval nor pdf"
