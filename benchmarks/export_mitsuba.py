"""Write a lift-gl scene as a Mitsuba 3 scene (XML + PLY meshes), for side-by-side baselines.

    python benchmarks/export_mitsuba.py SCENE OUTDIR [--size 128] [--scene-filter]

The film's filter is a box over each pixel, unless --scene-filter writes the scene's own
pixel filter (pbrt's triangle as Mitsuba's tent, a gaussian as Mitsuba's gaussian), which is
right at the scene's own film size.

Covers what the baseline scenes use: diffuse materials, smooth glass, area emitters on triangle meshes
and spheres, a constant environment, the perspective camera, path integrator depth. Mitsuba's
max_depth counts path vertices from the camera: a lift-gl max_depth of N bounces is N + 1.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

from lift_gl import load_scene


def _rgb(v) -> str:
    return ", ".join(f"{float(x):.9g}" for x in v)


def _rfilter(scene, scene_filter: bool) -> str:
    f = scene.pixel_filter
    if not scene_filter or f is None or f.kind == "box":
        return '<rfilter type="box"/>'
    if f.kind == "triangle":
        return f'<rfilter type="tent"><float name="radius" value="{max(f.radius):.9g}"/></rfilter>'
    stddev = (0.5 / f.alpha) ** 0.5  # pbrt's exp(-alpha x^2) is Mitsuba's exp(-x^2 / (2 stddev^2))
    return f'<rfilter type="gaussian"><float name="stddev" value="{stddev:.9g}"/></rfilter>'


def export(scene, out: Path, size, scene_filter: bool = False) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    cam = scene.camera
    lines = ['<scene version="3.0.0">',
             f'  <integrator type="path"><integer name="max_depth" value="{scene.max_depth + 1}"/></integrator>',
             '  <sensor type="perspective">',
             f'    <float name="fov" value="{cam.fov_deg}"/><string name="fov_axis" value="y"/>',
             '    <transform name="to_world">',
             f'      <lookat origin="{_rgb(cam.position)}" target="{_rgb(cam.target)}" up="{_rgb(cam.up)}"/>',
             '    </transform>',
             '    <sampler type="independent"><integer name="sample_count" value="16"/></sampler>',
             f'    <film type="hdrfilm"><integer name="width" value="{size[0]}"/><integer name="height" value="{size[1]}"/>',
             f'      {_rfilter(scene, scene_filter)}<string name="pixel_format" value="rgb"/></film>',
             '  </sensor>']
    for i, m in enumerate(scene.materials):
        if m.type == "dielectric" and m.alpha == 0:  # smooth glass, `base_color` tinting transmission
            lines.append(f'  <bsdf type="dielectric" id="mat{i}"><float name="int_ior" value="{m.ior:.9g}"/>'
                         f'<float name="ext_ior" value="1"/>'
                         f'<rgb name="specular_transmittance" value="{_rgb(m.base_color)}"/></bsdf>')
            continue
        if m.type != "diffuse":
            raise SystemExit(f"export_mitsuba: material {m.name!r} ({m.type}) is not exported")
        # lift-gl (like pbrt) shades opaque surfaces from both sides; Mitsuba needs twosided.
        lines.append(f'  <bsdf type="twosided" id="mat{i}"><bsdf type="diffuse">'
                     f'<rgb name="reflectance" value="{_rgb(m.base_color)}"/></bsdf></bsdf>')
    for i, mesh in enumerate(scene.meshes):
        path = out / f"mesh{i}.ply"
        trimesh.Trimesh(mesh.positions, mesh.indices, process=False).export(path)
        mat = scene.materials[mesh.material]
        lines.append(f'  <shape type="ply"><string name="filename" value="{path.name}"/>'
                     f'<boolean name="face_normals" value="true"/><ref id="mat{mesh.material}"/>')
        if mat.is_emissive:
            lines.append(f'    <emitter type="area"><rgb name="radiance" value="{_rgb(mat.emission)}"/></emitter>')
        lines.append('  </shape>')
    for s in scene.spheres:
        mat = scene.materials[s.material]
        emitter = (f'<emitter type="area"><rgb name="radiance" value="{_rgb(mat.emission)}"/></emitter>'
                   if mat.is_emissive else "")
        lines.append(f'  <shape type="sphere"><point name="center" value="{_rgb(s.center)}"/>'
                     f'<float name="radius" value="{s.radius}"/><ref id="mat{s.material}"/>{emitter}</shape>')
    if scene.environment is not None:
        lines.append(f'  <emitter type="constant"><rgb name="radiance" value="{_rgb(scene.environment.radiance)}"/></emitter>')
    lines.append('</scene>')
    xml = out / "scene.xml"
    xml.write_text("\n".join(lines) + "\n")
    return xml


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene")
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--scene-filter", action="store_true", help="the scene's pixel filter instead of a box")
    args = parser.parse_args()
    print(export(load_scene(args.scene), args.out, (args.size, args.size), args.scene_filter))


if __name__ == "__main__":
    main()
