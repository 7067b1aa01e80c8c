"""The Mitsuba XML importer on small files written here (Mitsuba 3 and 0.5 spellings, bad
input), and the Mitsuba 3 reference scenes of ../shared/refs/mitsuba rendered against their
references with a tolerance from our own noise (two seeds)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from lift_gl import metrics
from lift_gl.errors import SceneError
from lift_gl.image_io import write_image
from lift_gl.renderer import Renderer
from lift_gl.scene.envmap import direction_to_uv
from lift_gl.scene.loader import SceneWarning, load_scene
from lift_gl.scene.primitives import geometric_normals

MITSUBA3 = """<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="40"/>
    <integrator type="path"><integer name="max_depth" value="6"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world"><lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="30"/></film>
    </sensor>
    <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.6, 0.1, 0.1"/></bsdf>
    <bsdf type="twosided" id="metal">
        <bsdf type="roughconductor">
            <string name="material" value="Au"/>
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.2"/>
            <rgb name="specular_reflectance" value="0.5, 0.5, 0.5"/>
        </bsdf>
    </bsdf>
    <bsdf type="roughplastic" id="plastic">
        <string name="distribution" value="ggx"/>
        <float name="alpha" value="0.05"/>
        <float name="int_ior" value="1.6"/>
        <boolean name="nonlinear" value="true"/>
        <rgb name="diffuse_reflectance" value="0.2, 0.4, 0.6"/>
    </bsdf>
    <shape type="rectangle" id="right">
        <transform name="to_world"><scale value="0.5"/><rotate y="1" angle="-90"/><translate x="1" y="1"/></transform>
        <ref id="red"/>
    </shape>
    <shape type="cube">
        <transform name="to_world"><matrix value="0.2 0 0 -0.5  0 0.2 0 0.2  0 0 0.2 0  0 0 0 1"/></transform>
        <ref name="bsdf" id="metal"/>
    </shape>
    <shape type="sphere">
        <point name="center" x="0.5" y="0.3" z="0"/>
        <float name="radius" value="0.3"/>
        <bsdf type="dielectric"><string name="int_ior" value="water"/></bsdf>
    </shape>
    <shape type="disk">
        <transform name="to_world"><scale value="0.25"/><rotate x="1" angle="90"/><translate y="2"/></transform>
        <ref id="plastic"/>
        <emitter type="area"><rgb name="radiance" value="10, 10, 10"/></emitter>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
    <emitter type="directional">
        <vector name="direction" x="0" y="-1" z="-1"/>
        <rgb name="irradiance" value="2, 2, 2"/>
    </emitter>
</scene>
"""

# The same scene as Mitsuba 0.5 wrote it: camelCase names, toWorld, intIOR, maxDepth.
MITSUBA05 = (MITSUBA3.replace('version="3.0.0"', 'version="0.5.0"').replace("max_depth", "maxDepth")
             .replace("fov_axis", "fovAxis").replace("to_world", "toWorld").replace("int_ior", "intIOR")
             .replace("specular_reflectance", "specularReflectance").replace("diffuse_reflectance", "diffuseReflectance")
             .replace("sample_count", "sampleCount"))


def load_quietly(path):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        scene = load_scene(path)
    return scene, [str(w.message) for w in record if issubclass(w.category, SceneWarning)]


def _project_x(scene, point):
    right, _, _ = scene.camera.basis()
    return float(np.dot(np.asarray(point) - scene.camera.position, right))


@pytest.mark.parametrize("text", [MITSUBA3, MITSUBA05], ids=["mitsuba3", "mitsuba0.5"])
def test_mitsuba_scene_loads_every_part(tmp_path, text):
    path = tmp_path / "scene.xml"
    path.write_text(text)
    scene, messages = load_quietly(path)
    assert messages == [], messages
    assert scene.max_depth == 5  # Mitsuba's 6 path vertices are 5 bounces
    assert scene.film_size == (40, 30)  # $res
    # fov 45 across x on a 40x30 film: the vertical fov follows.
    assert scene.camera.fov_deg == pytest.approx(np.degrees(2 * np.arctan(np.tan(np.radians(22.5)) * 30 / 40)))
    np.testing.assert_allclose(scene.camera.position, [0, 1, 5])
    # Mitsuba's camera shows +x (the red rectangle at x = 1) on the image's right.
    rect = scene.meshes[0]
    assert _project_x(scene, rect.positions.mean(axis=0)) > 0
    # rotate -90 about y turns the rectangle's +z normal to -x: facing into the room.
    n = geometric_normals(rect.positions, rect.indices)
    assert (n[:, 0] < 0).all()
    np.testing.assert_allclose(np.ptp(rect.positions, axis=0), [0, 1, 1], atol=1e-9)  # scale 0.5 of [-1, 1]
    mats = scene.materials
    red = mats[rect.material]
    assert red.type == "diffuse" and np.allclose(red.base_color, [0.6, 0.1, 0.1])
    cube = scene.meshes[1]
    metal = mats[cube.material]
    assert metal.type == "conductor" and metal.alpha == pytest.approx(0.2)
    np.testing.assert_allclose(metal.eta, [0.143119, 0.374957, 1.442479])  # the Au preset
    np.testing.assert_allclose(metal.specular, 0.5)
    np.testing.assert_allclose(cube.positions.min(axis=0), [-0.7, 0.0, -0.2], atol=1e-9)  # row-major matrix
    sphere = scene.spheres[0]
    np.testing.assert_allclose([*sphere.center, sphere.radius], [0.5, 0.3, 0, 0.3])
    glass = mats[sphere.material]
    assert glass.type == "dielectric" and glass.ior == pytest.approx(1.3330 / 1.000277)
    disk = scene.meshes[2]
    lamp = mats[disk.material]
    assert lamp.type == "plastic" and lamp.nonlinear and lamp.ior == pytest.approx(1.6 / 1.000277)
    np.testing.assert_allclose(lamp.emission, 10)
    # The disk keeps its area (pi r^2) and, rotated +90 about x, faces down (-y).
    tri = disk.positions[disk.indices]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    assert area == pytest.approx(np.pi * 0.25 ** 2, rel=1e-6)  # float32 vertices
    assert (geometric_normals(disk.positions, disk.indices)[:, 1] < 0).all()
    np.testing.assert_allclose(scene.environment.radiance, 0.1)
    light = scene.distant_lights[0]
    np.testing.assert_allclose(light.direction, np.array([0, 1, 1]) / np.sqrt(2))  # towards the light
    np.testing.assert_allclose(light.irradiance, 2)


def test_unknown_elements_and_parameters_warn_once_with_their_line(tmp_path):
    path = tmp_path / "odd.xml"
    path.write_text("""<scene version="0.5.0">
    <mode type="final"/>
    <integrator type="path">
        <integer name="maxDepth" value="3"/>
        <integer name="sampleNum" value="100"/>
    </integrator>
    <sensor type="perspective">
        <hide type="sobol"/>
        <transform name="toWorld"><lookat origin="0,0,3" target="0,0,0"/></transform>
    </sensor>
    <mode type="other"/>
    <shape type="rectangle"><bsdf type="fancy"/></shape>
    <shape type="cylinder"/>
    <shape type="rectangle">
        <bsdf type="roughplastic"><float name="alpha" value="0.1"/></bsdf>
    </shape>
    <emitter type="point"/>
</scene>
""")
    scene, messages = load_quietly(path)
    expected = [("odd.xml:2:", "unknown element <mode>"), ("odd.xml:5:", "'sample_num' is not supported"),
                ("odd.xml:8:", "unknown element <hide>"), ("odd.xml:12:", "BSDF 'fancy' is not supported"),
                ("odd.xml:13:", "shape 'cylinder' is not supported"),
                ("odd.xml:15:", "beckmann microfacets are approximated by GGX of the same alpha for roughplastic"),
                ("odd.xml:17:", "emitter 'point' is not supported")]
    for where, what in expected:
        assert sum(where in m and what in m for m in messages) == 1, (where, what, messages)
    assert not any("odd.xml:11:" in m for m in messages), "the second <mode> is not reported again"
    assert len(scene.meshes) == 2 and scene.max_depth == 2
    assert scene.materials[scene.meshes[1].material].type == "plastic"


@pytest.mark.parametrize("body, line, text", [
    ('<shape type="rectangle">\n<ref id="nope"/>\n</shape>', 3, "unknown id 'nope'"),
    ('<shape type="sphere">\n<float name="radius" value="big"/>\n</shape>', 3, "'big' is not a list of numbers"),
    ('<shape type="obj">\n<string name="filename" value="missing.obj"/>\n</shape>', 2, "missing.obj"),
    ('<shape type="rectangle">\n<float name="x" value="$undefined"/>\n</shape>', 3, "'$undefined' is not defined"),
    ('<shape type="rectangle">\n</shap>', 3, "XML syntax error"),
    ('<emitter type="envmap">\n<string name="filename" value="sky.exr"/>\n</emitter>', 2, "sky.exr"),
    ('<shape type="rectangle">\n<transform name="to_world"><matrix value="1 2 3"/></transform>\n</shape>', 3,
     "<matrix> needs 16"),
])
def test_bad_mitsuba_input_names_file_and_line(tmp_path, body, line, text):
    path = tmp_path / "bad.xml"
    path.write_text(f'<scene version="3.0.0">\n{body}\n</scene>\n')
    with pytest.raises(SceneError) as info:
        load_quietly(path)
    err = info.value
    assert err.line == line and text in err.message, str(err)
    assert str(err).startswith(f"{path}:{line}: ")


def test_obj_normals_textures_and_envmap_frame(tmp_path):
    """face_normals drops normals; without it Mitsuba computes smooth ones; bitmap textures
    attach to the material; envmap's to_world is the map's frame."""
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0.5\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n"
                                      "f 1/1 2/2 3/3\nf 2/2 4/4 3/3\n")
    from PIL import Image
    Image.fromarray(np.full((2, 2, 3), 200, np.uint8)).save(tmp_path / "grey.png")
    write_image(tmp_path / "sky.exr", np.ones((4, 8, 3), np.float32))
    path = tmp_path / "s.xml"
    path.write_text("""<scene version="3.0.0">
    <shape type="obj"><string name="filename" value="tri.obj"/><boolean name="face_normals" value="true"/></shape>
    <shape type="obj"><string name="filename" value="tri.obj"/>
        <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="grey.png"/></texture></bsdf>
    </shape>
    <emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="3"/>
        <transform name="to_world"><rotate y="1" angle="90"/></transform>
    </emitter>
    <sensor type="perspective"><transform name="to_world"><lookat origin="0,0,3" target="0,0,0"/></transform></sensor>
</scene>
""")
    scene, messages = load_quietly(path)
    assert messages == []
    flat, smooth = scene.meshes
    assert flat.normals is None
    assert smooth.normals is not None
    # The shared edge's vertices average both faces' normals (angle-weighted).
    assert not np.allclose(smooth.normals, smooth.normals[0])
    mat = scene.materials[smooth.material]
    assert mat.texture is not None and scene.textures[mat.texture].srgb
    np.testing.assert_allclose(smooth.uvs, [[0, 0], [1, 0], [0, 1], [1, 1]])  # OBJ's v, bottom-left origin
    env = scene.environment
    np.testing.assert_allclose(env.radiance, 3)
    # Mitsuba: d_world = to_world @ d_map; rotating +90 about y takes the map's +x (u = 1/4,
    # on the horizon) to world -z.
    np.testing.assert_allclose(direction_to_uv(np.linalg.inv(env.to_world) @ [0, 0, -1.0]), [0.25, 0.5], atol=1e-12)


# ---- the Mitsuba 3 reference scenes -------------------------------------------------------------
SIZE = 32  # the 128x128 references box-downsampled by 4
# glossy_mis is noisy: at 512 spp a GGX alpha 15% off shows as D = 4 standard errors, 50% off
# as 10 (measured); 2 bounces fewer in cbox fails at 128 spp.
SPP = {"furnace": 64, "cbox": 128, "glossy_mis": 512}


@pytest.mark.parametrize("name", list(SPP))
def test_mitsuba_reference_scene_converges_to_its_reference(shared_dir, name):
    """Two independent renders a, b: their difference measures our noise, so
    D = mean(w ((a + b)/2 - ref)^2) - mean(w (a - b)^2) / 4, w = 1 / (ref^2 + 1e-2), estimates
    the squared bias in relMSE terms (the reference's own noise, 7168 spp over 16 pixels per
    pixel here, is negligible). D's per-pixel terms are independent, so its standard error
    is their standard deviation / sqrt(count). Unbiased rendering of the same models: D
    within 4 standard errors of 0, and the image mean within 4 standard errors."""
    folder = shared_dir / "refs" / "mitsuba" / name
    scene, messages = load_quietly(folder / "scene.xml")
    assert messages == []
    ref = metrics.resize_to(np.load(folder / "reference.npy"), (SIZE, SIZE)).astype(np.float64)
    images = []
    for seed in (1, 2):
        r = Renderer(scene, size=(SIZE, SIZE), seed=seed)
        images.append(r.render(spp=SPP[name]).astype(np.float64))
        assert r.stats.dropped_samples == 0
        r.release()
    a, b = images
    w = 1.0 / (ref ** 2 + metrics.REL_MSE_EPS)
    terms = (w * ((a + b) / 2 - ref) ** 2 - w * (a - b) ** 2 / 4).ravel()
    bias2, se = terms.mean(), terms.std(ddof=1) / np.sqrt(terms.size)
    assert bias2 < 4 * se, (name, bias2, se, metrics.rel_mse((a + b) / 2, ref))
    mean, want = ((a + b) / 2).reshape(-1, 3).mean(axis=0), ref.reshape(-1, 3).mean(axis=0)
    mean_se = np.sqrt(((a - b) ** 2 / 4).reshape(-1, 3).mean(axis=0) / (SIZE * SIZE))
    assert np.all(np.abs(mean - want) < 4 * mean_se + 1e-6), (name, mean, want, mean_se)


def test_rough_conductors_keep_beckmann(tmp_path):
    path = tmp_path / "b.xml"
    path.write_text("""<scene version="3.0.0">
    <shape type="rectangle"><bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="roughconductor"><string name="distribution" value="ggx"/></bsdf></shape>
    <shape type="rectangle"><bsdf type="roughconductor"><string name="distribution" value="phong"/></bsdf></shape>
</scene>""")
    with pytest.raises(SceneError) as info:
        load_quietly(path)
    assert info.value.line == 4 and "unknown microfacet distribution 'phong'" in info.value.message
    path.write_text(path.read_text().replace('    <shape type="rectangle"><bsdf type="roughconductor"><string name="distribution" value="phong"/></bsdf></shape>\n', ""))
    scene, messages = load_quietly(path)
    beckmann, ggx = (scene.materials[m.material] for m in scene.meshes)
    assert (beckmann.distribution, beckmann.alpha) == ("beckmann", 0.3)  # Mitsuba's default
    assert (ggx.distribution, ggx.alpha) == ("ggx", 0.1)
    from lift_gl.scene.features import SceneFeatures
    assert SceneFeatures.of(scene).beckmann
