"""F4 Edit: live scene edits. Lights (radiance, colour, size, position; drag one in the image
to move it), materials (colour, roughness), and Save as .toml. Each edit restarts
accumulation; the work is in app/scene_editor.py (tested headless)."""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui

from ...scene import edit
from . import Panel, UiState, push_label_room

SIZE_RANGE = (0.1, 10.0)  # of the size the object had when the scene was opened
LABELS = ("radiance", "light colour", "size", "position", "material", "colour", "roughness", "path")


class EditPanel(Panel):
    title = "Edit"
    key = "F4"
    visible = False

    def __init__(self):
        self._path_text = ""
        self._editor = None  # the editor the path text belongs to (a new one per scene)

    def draw(self, session, ui: UiState) -> None:
        editor = session.editor
        if not self.begin(ui):
            return
        scene = editor.scene
        if editor is not self._editor:
            self._editor, self._path_text = editor, str(editor.save_path)
        push_label_room(LABELS)
        imgui.text_wrapped("Click an object in the image to select it; drag a light (or the selected "
                           "object) to move it. Every edit restarts accumulation.")
        self._lights(editor, scene)
        self._material(editor, scene)
        self._save(editor)
        imgui.pop_item_width()
        self.end(ui)

    def _lights(self, editor, scene):
        imgui.separator_text("Lights")
        for ref in editor.emitters():
            if imgui.selectable(f"{editor.name(ref)}##{ref.kind}{ref.index}", ref == editor.selected)[0]:
                editor.select(ref)
        if not editor.emitters():
            imgui.text_disabled("no emitters in this scene")
        if editor.selected is None:
            return
        ref = editor.selected
        imgui.separator_text(f"Selected: {editor.name(ref)}")
        if editor.selected_is_emitter:
            radiance, colour = edit.light_of(scene, ref)
            changed, radiance = imgui.drag_float("radiance", radiance, max(radiance, 1.0) * 0.01, 0.0, 1e6, "%.3f",
                                                 imgui.SliderFlags_.logarithmic)
            imgui.set_item_tooltip("emitted radiance of the brightest channel (W / sr m^2)")
            changed_colour, colour = imgui.color_edit3("light colour", [float(c) for c in colour],
                                                       imgui.ColorEditFlags_.float)
            if changed or changed_colour:
                peak = max(colour) if max(colour) > 0 else 1.0
                editor.set_light(max(radiance, 0.0), np.asarray(colour) / peak)
        size = editor.size_of(ref)
        changed, new_size = imgui.slider_float("size", size, *SIZE_RANGE, "%.2f x", imgui.SliderFlags_.logarithmic)
        imgui.set_item_tooltip("scale about its centre, relative to the scene as opened "
                               "(radiance stays: a larger light is more powerful)")
        if changed and new_size > 0:
            editor.scale(new_size / size)
        center = edit.object_center(scene, ref)
        changed, moved = imgui.drag_float3("position", [float(v) for v in center], 0.01, 0.0, 0.0, "%.3f")
        imgui.set_item_tooltip("the centre of its bounding box, world space")
        if changed:
            editor.move(np.asarray(moved) - center)

    def _material(self, editor, scene):
        imgui.separator_text("Material")
        names = [m.name for m in scene.materials]
        if editor.material is None or editor.material >= len(names):
            editor.material = 0
        changed, index = imgui.combo("material", editor.material, names)
        if changed:
            editor.material = index
        material = scene.materials[editor.material]
        imgui.text_disabled(material.type + (" (emits)" if material.is_emissive else ""))
        changed, colour = imgui.color_edit3("colour", [float(c) for c in material.base_color],
                                            imgui.ColorEditFlags_.float)
        imgui.set_item_tooltip("diffuse albedo; conductor F0 (without a metal preset); glass tint")
        if changed:
            editor.set_colour(np.clip(colour, 0.0, None))
        if material.type != "diffuse":
            changed, roughness = imgui.slider_float("roughness", edit.roughness_of(material), 0.0, 1.0, "%.3f")
            imgui.set_item_tooltip("perceptual roughness (GGX alpha = roughness^2); 0 is smooth")
            if changed:
                editor.set_roughness(roughness)

    def _save(self, editor):
        imgui.separator_text("Save")
        _, self._path_text = imgui.input_text("path##save", self._path_text)
        imgui.same_line()
        if imgui.button("Save"):
            editor.save(self._path_text.strip())
        if editor.dirty:
            imgui.text_colored(imgui.ImVec4(1.0, 0.8, 0.3, 1.0), "unsaved edits")
        elif editor.saved_to is not None:
            imgui.text_disabled(f"saved: {editor.saved_to.name}")
