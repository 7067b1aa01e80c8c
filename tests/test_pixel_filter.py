"""The scene's pixel filter: importers keep it, the sampler draws subpixel offsets from it,
and an image of a straight emitter edge shows the analytic filtered profile.

The edge test is independent of lift_gl/passes/pixel_filter.py: a pixel's value across a
vertical edge between radiance 1 and 0 is the probability that its sample lands on the bright
side, the kernel's cumulative distribution, written here in closed form for the triangle
filter (and its box-downsampled comb). The frames' subpixel offsets are a Halton sequence, so
the error is its discrepancy (at most about 2/N over N frames along one axis), not noise.
"""
from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from lift_gl import load_scene
from lift_gl.chi2 import pearson_chi2
from lift_gl.errors import SceneError
from lift_gl.passes.pixel_filter import filtered_jitter, pixel_kernel
from lift_gl.renderer import Renderer
from lift_gl.scene.model import PixelFilter
from lift_gl.scene.toml_writer import save_toml
from lift_gl.testing import require_opencl

SHARED = Path(__file__).resolve().parent.parent.parent / "shared"
FRAMES = 256


def tent_cdf(t: np.ndarray, radius: float) -> np.ndarray:
    """P(X < t) for X with a triangle density of half-width `radius` around 0."""
    t = np.clip(np.asarray(t, dtype=np.float64), -radius, radius)
    left = (t + radius) ** 2 / (2 * radius ** 2)
    right = 1 - (radius - t) ** 2 / (2 * radius ** 2)
    return np.where(t <= 0, left, right)


def edge_profile(width: int, film_per_pixel: int, radius_film_px: float) -> np.ndarray:
    """Expected value of each column for an edge at x = width / 2 (bright on the left):
    the mean over the film pixels a column averages of the triangle filter's CDF."""
    film_px = 1.0 / film_per_pixel                      # a film pixel, in rendered pixels
    columns = np.arange(width)[:, None]
    centres = columns + (np.arange(film_per_pixel)[None, :] + 0.5) * film_px
    return tent_cdf(width / 2 - centres, radius_film_px * film_px).mean(axis=1)


def edge_scene(tmp_path: Path, film: int, filter_lines: str) -> Path:
    path = tmp_path / "edge.toml"
    path.write_text(textwrap.dedent(f"""
        [camera]
        position = [0, 0, 5]
        target = [0, 0, 0]
        fov = 30
        [film]
        size = [{film}, {film}]
        {filter_lines}
        [materials.lamp]
        color = 0
        emission = 1
        [[objects]]
        type = "quad"
        material = "lamp"
        corner = [-10, -10, 0]
        u = [10, 0, 0]
        v = [0, 20, 0]
        """))
    return path


def render_edge(scene_path: Path, size: int, integrator: str = "pt") -> np.ndarray:
    r = Renderer(load_scene(scene_path), size=(size, size), integrator=integrator, seed=3)
    try:
        image = r.render(spp=FRAMES).astype(np.float64)
        assert r.stats.dropped_samples == 0
    finally:
        r.release()
    return image[..., 0].mean(axis=0)  # the column means (every row sees the same edge)


TOLERANCE = 2.0 / FRAMES + 2e-3  # Halton's discrepancy along x, plus the sampler's table


@pytest.mark.parametrize("film, size, radius", [(32, 32, 2.0), (128, 32, 3.0)])
def test_edge_shows_the_filtered_profile(tmp_path, film, size, radius):
    path = edge_scene(tmp_path, film, f'filter = "triangle"\nfilter_radius = {radius}')
    got = render_edge(path, size)
    want = edge_profile(size, film // size, radius)
    assert np.max(np.abs(got - want)) < TOLERANCE, np.round(np.c_[got, want][size // 2 - 4:size // 2 + 4], 4)
    # ...and a box over the pixel (no filter) would not pass: the test tells them apart.
    box = np.clip(size / 2 - np.arange(size), 0, 1)
    assert np.max(np.abs(box - want)) > 5 * TOLERANCE


def test_edge_with_camera_rays_matches_the_gbuffer(tmp_path):
    from test_render_e2e import _camera_copy_of_pt  # the pt plugin with primary = "camera"
    path = edge_scene(tmp_path, 32, 'filter = "triangle"\nfilter_radius = 2.0')
    got = render_edge(path, 32, str(_camera_copy_of_pt(tmp_path)))
    assert np.max(np.abs(got - edge_profile(32, 1, 2.0))) < TOLERANCE


def test_no_filter_keeps_a_box_over_the_pixel(tmp_path):
    got = render_edge(edge_scene(tmp_path, 32, ""), 32)
    assert np.max(np.abs(got - np.clip(16.0 - np.arange(32), 0, 1))) < TOLERANCE
    assert filtered_jitter((0.25, 0.75), None, (32, 32), (32, 32)) == (0.25, 0.75)


@pytest.mark.parametrize("pixel_filter, film, size", [
    (PixelFilter("triangle", (1.0, 1.0)), 1024, 128),
    (PixelFilter("triangle", (2.0, 1.0)), 64, 64),
    (PixelFilter("gaussian", (2.0, 2.0), alpha=2.0), 256, 128),
    (PixelFilter("box", (1.5, 1.5)), 100, 100),
])
def test_sampled_offsets_follow_the_kernel(pixel_filter, film, size):
    """Chi-square of offsets drawn from uniform numbers against the kernel's bin masses."""
    rng = np.random.default_rng(5)
    n = 20000
    offsets = np.array([filtered_jitter(tuple(u), pixel_filter, (film, film), (size, size))
                        for u in rng.random((n, 2))])
    for axis in (0, 1):
        x, density = pixel_kernel(pixel_filter, axis, film, size)
        assert abs(np.trapezoid(density, x) - 1) < 1e-9
        edges = np.linspace(x[0], x[-1], 21)
        fine = np.linspace(x[0], x[-1], 200001)
        pdf = np.interp(fine, x, density)
        mass = np.array([np.trapezoid(pdf[(fine >= a) & (fine <= b)], fine[(fine >= a) & (fine <= b)])
                         for a, b in zip(edges, edges[1:])])
        keep = mass * n > 5
        counts, _ = np.histogram(offsets[:, axis], bins=edges)
        expected = mass[keep] / mass[keep].sum() * counts[keep].sum()
        chi2, dof, p = pearson_chi2(counts[keep], expected)
        assert p > 1e-3, (axis, chi2, dof, p)


def test_triangle_downsampled_is_a_trapezoid():
    """A radius-1 triangle filter box-averaged over 8 film pixels is box(1) * box(1/8): flat to
    7/16 of a pixel from the centre, linear to zero at 9/16."""
    x, density = pixel_kernel(PixelFilter("triangle", (1.0, 1.0)), 0, 1024, 128)
    d = np.abs(x - 0.5)
    want = np.clip((9 / 16 - d) * 8, 0, 1)
    assert np.max(np.abs(density - want)) < 1e-3


# --------------------------------------------------------------------------- importers
def test_pbrt_pixel_filter_is_read(tmp_path):
    path = tmp_path / "f.pbrt"
    path.write_text('LookAt 0 0 5 0 0 0 0 1 0\nCamera "perspective" "float fov" [30]\n'
                    'PixelFilter "gaussian" "float xwidth" [1.5] "float ywidth" [2] "float alpha" [3]\n'
                    'Film "image" "integer xresolution" [64] "integer yresolution" [32]\nWorldBegin\nWorldEnd\n')
    f = load_scene(path).pixel_filter
    assert (f.kind, f.radius, f.alpha) == ("gaussian", (1.5, 2.0), 3.0)
    path.write_text(path.read_text().replace('"gaussian" "float xwidth" [1.5] "float ywidth" [2] "float alpha" [3]',
                                             '"box"'))
    assert load_scene(path).pixel_filter is None  # pbrt's default box is a box over the pixel
    path.write_text(path.read_text().replace('PixelFilter "box"', 'PixelFilter "triangle" "float xwidth" [-1]'))
    with pytest.raises(SceneError, match=r"f\.pbrt:3"):
        load_scene(path)


def test_pbrt_mitchell_warns_and_uses_a_box(tmp_path):
    path = tmp_path / "m.pbrt"
    path.write_text('Camera "perspective"\nPixelFilter "mitchell"\nWorldBegin\nWorldEnd\n')
    with pytest.warns(UserWarning, match=r"m\.pbrt:2.*negative lobes"):
        assert load_scene(path).pixel_filter is None


@pytest.mark.parametrize("rfilter, want", [
    ('<rfilter type="tent"/>', ("triangle", (1.0, 1.0))),
    ('<rfilter type="tent"><float name="radius" value="2"/></rfilter>', ("triangle", (2.0, 2.0))),
    ('<rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>', ("gaussian", (1.0, 1.0))),
    ('<rfilter type="box"/>', None),
    ('', ("gaussian", (2.0, 2.0))),  # Mitsuba's default
])
def test_mitsuba_rfilter_is_read(tmp_path, rfilter, want):
    path = tmp_path / "s.xml"
    path.write_text(f'<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">'
                    f'<integer name="width" value="32"/><integer name="height" value="32"/>{rfilter}'
                    f'</film></sensor></scene>')
    f = load_scene(path).pixel_filter
    assert (None if f is None else (f.kind, f.radius)) == want
    if want and want[0] == "gaussian":
        assert f.alpha == pytest.approx(0.5 / (want[1][0] / 4) ** 2)


def test_toml_filter_round_trips_and_bad_values_name_the_line(tmp_path):
    path = edge_scene(tmp_path, 32, 'filter = "gaussian"\nfilter_radius = [1.5, 2.5]\nfilter_alpha = 1.0')
    scene = load_scene(path)
    assert (scene.pixel_filter.kind, scene.pixel_filter.radius, scene.pixel_filter.alpha) == ("gaussian", (1.5, 2.5), 1.0)
    out = tmp_path / "out" / "copy.toml"
    save_toml(scene, out)
    copy = load_scene(out).pixel_filter
    assert (copy.kind, copy.radius, copy.alpha) == ("gaussian", (1.5, 2.5), 1.0)
    for lines, line in (('filter = "mitchell"', 8), ('filter = "triangle"\nfilter_radius = -1', 9),
                        ('filter_radius = 2', 8)):
        with pytest.raises(SceneError, match=rf"edge\.toml:{line}"):
            load_scene(edge_scene(tmp_path, 32, lines))


@pytest.mark.skipif(not (SHARED / "scenes_lift/cornell-box/scene.pbrt").exists(),
                    reason="../shared (Lift's scenes) is not here")
def test_lift_cornell_box_asks_for_pbrt_triangle_filter():
    f = load_scene(SHARED / "scenes_lift/cornell-box/scene.pbrt").pixel_filter
    assert (f.kind, f.radius) == ("triangle", (1.0, 1.0))


SPLAT_PLUGIN = """
    vec3 radiance(Ray ray, Hit hit, inout Rng rng) {
        // One invocation adds 1 at a fixed image position every sample; no pixel sees anything.
        if (all(equal(gl_GlobalInvocationID.xy, uvec2(0u)))) splat(vec2(10.3, 12.7), vec3(1.0));
        return vec3(0.0);
    }
"""


@pytest.mark.parametrize("filter_lines, radius", [('filter = "triangle"\nfilter_radius = 2.0', 2.0), ("", None)])
def test_a_splat_is_spread_by_the_kernel(tmp_path, filter_lines, radius):
    """Light tracing's splat (lift/splat.glsl): a unit splat at (10.3, 12.7) lands on every
    pixel whose kernel covers it, weighted by the kernel there: the separable triangle density
    (closed form) or, without a filter, all of it on the pixel that contains it."""
    folder = tmp_path / "splatter"
    folder.mkdir()
    (folder / "plugin.toml").write_text('name = "splatter"\nlanguage = "glsl"\nentry = "splatter.glsl"\n'
                                        'primary = "camera"\nsplats = true\n')
    (folder / "splatter.glsl").write_text(textwrap.dedent(SPLAT_PLUGIN))
    scene = load_scene(edge_scene(tmp_path, 24, filter_lines))
    r = Renderer(scene, size=(24, 24), integrator=str(folder), seed=1, samples_per_frame=1)
    image = r.render(spp=4).astype(np.float64)[::-1, :, 0]  # rows from the bottom: pixel y up
    r.release()
    c = np.arange(24) + 0.5
    if radius is None:
        want = np.outer(np.floor(c) == 12, np.floor(c) == 10).astype(float)
    else:
        tent = lambda d: np.maximum(0.0, 1 - np.abs(d) / radius) / radius  # density, integral 1
        want = np.outer(tent(12.7 - c), tent(10.3 - c))
    assert abs(image.sum() - 1.0) < 0.01
    assert np.max(np.abs(image - want)) < 0.01 * want.max(), np.round(image[10:15, 8:13], 4)


def test_opencl_camera_rays_sample_the_filter(tmp_path):
    """An OpenCL plugin with traced camera rays (lift_gl/passes/trace_cl.py) draws its
    subpixel positions from the same kernel: 1 where the ray hits the emitter's quad."""
    require_opencl()
    folder = tmp_path / "hits_cl"
    folder.mkdir()
    (folder / "plugin.toml").write_text('name = "hits_cl"\nlanguage = "opencl"\nentry = "hits_cl.cl"\n'
                                        'primary = "camera"\n')
    (folder / "hits_cl.cl").write_text(textwrap.dedent("""
        float3 radiance(Ray ray, Hit hit, Rng* rng, const Scene* scene, const Params* params) {
            return (float3)(hit.prim == NO_HIT ? 0.0f : 1.0f);
        }
        """))
    path = edge_scene(tmp_path, 32, 'filter = "triangle"\nfilter_radius = 2.0')
    r = Renderer(load_scene(path), size=(32, 32), integrator=str(folder), seed=3, samples_per_frame=4)
    image = r.render(spp=1024).astype(np.float64)[..., 0]
    r.release()
    got, want = image.mean(axis=0), edge_profile(32, 1, 2.0)
    # Independent random subpixel positions (not the frames' Halton points): binomial noise
    # per column over 32 rows x 1024 samples.
    se = np.sqrt(want * (1 - want) / (32 * 1024))
    assert np.all(np.abs(got - want) <= 4.5 * se + 2e-3), np.round(np.c_[got, want][12:20], 4)


@pytest.mark.parametrize("kind, radius", [("triangle", 1.0), ("box", 0.5), ("gaussian", 2.0)])
def test_many_film_pixels_a_pixel_use_the_sums_limit(kind, radius):
    """Past MAX_FILM_CENTRES film pixels a rendered pixel the kernel is the filter averaged over
    the pixel (the sum's limit), so a film of any size costs the same: at the switch the
    sampled positions move by less than 0.0025 of a pixel, and the limit is reached."""
    from lift_gl.passes.pixel_filter import KNOTS, MAX_FILM_CENTRES, cdf_knots

    pixel_filter = PixelFilter(kind, (radius, radius))

    def inverse(film_per_pixel):
        (cdf, start, step), _ = cdf_knots(pixel_filter, (8 * film_per_pixel, 8), (8, 8))
        u = np.linspace(0.0, 1.0, 1001)
        return np.interp(u, cdf, start + step * np.arange(KNOTS))

    summed, limit = inverse(MAX_FILM_CENTRES), inverse(MAX_FILM_CENTRES + 1)
    assert np.abs(summed - limit).max() < 0.0025
    assert np.abs(inverse(10 ** 11) - np.linspace(0.0, 1.0, 1001)).max() < 1e-3  # a box over the pixel
