"""The viewer's live scene edits, with no GUI toolkit: pick the object under a pixel, select
an emitter or a material, change it, drag it with the mouse, save the scene as .toml.

Every edit goes through lift_gl/scene/edit.py on the session's Scene, then
`ViewSession.scene_edited` hands the scene to every Renderer (`Renderer.update_scene`:
the materials buffer alone for colours and roughness, a re-pack and BVH rebuild for moves
and sizes) and accumulation restarts. Mouse drags are gathered and applied once a frame.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import LiftError
from ..scene import edit
from ..scene.edit import ObjectRef
from ..scene.toml_writer import save_toml

GRAZING_COS = 0.2  # a flat light seen at a grazing angle is moved as if seen from above


def camera_ray(camera, size, pixel) -> tuple[np.ndarray, np.ndarray]:
    """Origin and unit direction of the pinhole ray through the centre of render pixel
    (x, y from the top left), as shaders/lift/camera.glsl builds it."""
    right, up, forward = camera.basis()
    w, h = size
    t = np.tan(np.radians(camera.fov_deg) / 2)
    ndc_x = (pixel[0] + 0.5) / w * 2 - 1
    ndc_y = (h - pixel[1] - 0.5) / h * 2 - 1
    d = forward + ndc_x * t * (w / h) * right + ndc_y * t * up
    return np.asarray(camera.position, np.float64), d / np.linalg.norm(d)


def ray_plane(origin, direction, point, normal) -> np.ndarray | None:
    denom = float(direction @ normal)
    if abs(denom) < 1e-9:
        return None
    t = float((point - origin) @ normal) / denom
    return origin + t * direction if t > 0 else None


class SceneEditor:
    def __init__(self, session):
        self.session = session
        self.selected: ObjectRef | None = None
        self.material: int | None = None  # the material the panel edits
        self.dirty = False  # edits not saved yet
        self.save_path = self.default_save_path()
        self.saved_to: Path | None = None
        self.sizes: dict = {}  # ObjectRef -> its size relative to the scene as opened
        self._drag_plane = None  # (point, normal) the dragged object slides in
        self._drag_from = None  # where the mouse ray met that plane last
        self._slide = None  # for a flat light seen edge-on: how view-plane motion maps onto it
        self._pending_move = np.zeros(3)

    @property
    def scene(self):
        return self.session.scene  # the session makes a new editor when it opens another scene

    def default_save_path(self) -> Path:
        p = self.session.scene_path
        stem = p.stem if p.stem.endswith("-edited") else p.stem + "-edited"
        return p.with_name(stem + ".toml")

    # ---- what there is --------------------------------------------------------------------
    def emitters(self) -> list[ObjectRef]:
        return edit.emitters(self.scene)

    def name(self, ref: ObjectRef) -> str:
        return edit.object_name(self.scene, ref)

    def select(self, ref: ObjectRef | None) -> None:
        self.selected = ref
        if ref is not None:
            self.material = edit.object_of(self.scene, ref).material

    @property
    def selected_is_emitter(self) -> bool:
        return self.selected is not None and self.selected in self.emitters()

    def pick(self, pixel) -> ObjectRef | None:
        """The object the G-buffer shows at render pixel (x, y from the top left), or None."""
        renderer = self.session.renderer
        w, h = renderer.size
        x, y = int(pixel[0]), int(pixel[1])
        if not (0 <= x < w and 0 <= y < h):
            return None
        if renderer.gbuffer is None:  # a camera-ray plugin: make it a G-buffer for picking
            renderer.aov("depth")
        else:  # what the camera sees now, through pixel centres (the last frame may be older)
            renderer.buffers.bind()
            renderer.gbuffer.run(renderer.camera, renderer.packed.bounds, (0.5, 0.5),
                                 renderer.scene_uniforms, renderer.camera_uniforms)
        data = renderer.gbuffer.fbo.read(viewport=(x, h - 1 - y, 1, 1), components=4, attachment=0, dtype="u4")
        prim = int(np.frombuffer(data, np.uint32)[0])
        if prim == 0:
            return None
        return self._object_of_primitive(prim - 1)

    def _object_of_primitive(self, prim: int) -> ObjectRef | None:
        packed = self.session.renderer.packed
        if prim >= packed.num_triangles:
            return ObjectRef("sphere", prim - packed.num_triangles)
        # Triangles are in BVH order on the GPU: find the mesh that holds these corners.
        corners = packed.tri_pos[prim, :, :3]
        shutter_open = self.scene.camera.shutter[0]
        origin = packed.origin if packed.origin is not None else np.zeros(3)  # pack.py rebases
        for i, mesh in enumerate(self.scene.meshes):
            if not len(mesh.indices):
                continue
            tris = mesh.positions[mesh.indices] - origin
            if mesh.velocity is not None and shutter_open:  # packed where it is when the shutter opens
                tris = tris + (mesh.velocity * shutter_open)[None, None, :]
            if np.any(np.all(tris.astype(np.float32) == corners[None], axis=(1, 2))):
                return ObjectRef("mesh", i)
        return None

    # ---- edits ----------------------------------------------------------------------------
    def _apply(self, change: str) -> bool:
        ok = self.session.scene_edited(geometry=change == edit.GEOMETRY)
        self.dirty = True
        return ok

    def _guarded(self, action) -> bool:
        try:
            change = action()
        except LiftError as exc:
            self.session.errors.add(exc)
            return False
        return self._apply(change)

    def set_light(self, radiance: float, colour) -> bool:
        ref = self.selected
        ok = self._guarded(lambda: edit.set_light(self.scene, ref, radiance, colour))
        self.material = edit.object_of(self.scene, ref).material  # it may have got its own copy
        return ok

    def scale(self, factor: float) -> bool:
        ref = self.selected
        ok = self._guarded(lambda: edit.scale_object(self.scene, ref, factor))
        if ok:
            self.sizes[ref] = self.size_of(ref) * factor
        return ok

    def size_of(self, ref: ObjectRef) -> float:
        return self.sizes.get(ref, 1.0)

    def move(self, delta) -> bool:
        return self._guarded(lambda: edit.move_object(self.scene, self.selected, delta))

    def set_colour(self, colour) -> bool:
        return self._guarded(lambda: edit.set_material_colour(self.scene, self.material, colour))

    def set_roughness(self, roughness: float) -> bool:
        return self._guarded(lambda: edit.set_material_roughness(self.scene, self.material, roughness))

    # ---- the mouse ------------------------------------------------------------------------
    def _mouse_ray(self, pixel):
        r = self.session.renderer
        return camera_ray(r.scene.camera, r.size, pixel)

    def press(self, pixel) -> bool:
        """A click on the image: select what is under it. True when that starts a drag (an
        emitter, or an object that was already selected): then the camera must not turn."""
        ref = self.pick(pixel)
        was_selected = ref is not None and ref == self.selected
        self.select(ref)
        if ref is None or not (was_selected or ref in self.emitters()):
            return False
        camera = self.session.renderer.scene.camera
        right, up, forward = camera.basis()
        normal = edit.facing(self.scene, ref)
        point = edit.object_center(self.scene, ref)
        self._slide = None
        if normal is None:  # a solid object: it moves in the plane facing the camera
            self._drag_plane = (point, forward)
        elif abs(float(forward @ normal)) >= GRAZING_COS:  # a flat light seen well: along its plane
            self._drag_plane = (point, normal)
        else:
            # A flat light seen edge-on (the Cornell box's ceiling light): the mouse moves in
            # the view plane, and its right/up become right/away-from-the-camera in the light's
            # own plane, so the light never leaves it.
            self._drag_plane = (point, forward)
            along_right = right - (right @ normal) * normal
            away = forward - (forward @ normal) * normal
            self._slide = (along_right / np.linalg.norm(along_right), away / np.linalg.norm(away), right, up)
        self._drag_from = ray_plane(*self._mouse_ray(pixel), *self._drag_plane)
        return self._drag_from is not None

    def drag(self, pixel) -> None:
        if self._drag_plane is None or self._drag_from is None:
            return
        hit = ray_plane(*self._mouse_ray(pixel), *self._drag_plane)
        if hit is None:
            return
        delta = hit - self._drag_from
        if self._slide is not None:
            along_right, away, right, up = self._slide
            delta = (delta @ right) * along_right + (delta @ up) * away
        self._pending_move += delta
        self._drag_from = hit

    def release(self) -> None:
        self._drag_plane = self._drag_from = None

    @property
    def dragging(self) -> bool:
        return self._drag_plane is not None

    def apply_pending(self) -> bool:
        """Once a frame: move the dragged object by what the mouse did since the last frame."""
        if not self._pending_move.any():
            return False
        delta, self._pending_move = self._pending_move, np.zeros(3)
        return self.move(delta)

    # ---- saving ---------------------------------------------------------------------------
    def save(self, path=None) -> Path | None:
        path = Path(path or self.save_path)
        try:
            save_toml(self.scene, path)
        except (LiftError, OSError) as exc:
            self.session.errors.add(exc)
            return None
        self.save_path = self.saved_to = path
        self.dirty = False
        return path
