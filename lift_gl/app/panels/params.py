"""A widget for each plugin parameter, chosen from its manifest entry (`[params.X]`).

| type  | widget                                                          |
| ----- | --------------------------------------------------------------- |
| bool  | checkbox                                                        |
| int   | slider when min and max are at most 32 apart, else a number box |
| float | slider when both bounds are given, else a drag box              |
| color | colour editor (linear RGB)                                      |

The manifest's `help` becomes the tooltip. Values are clamped to [min, max] before they are
handed to Renderer.set_params, which checks them again.
"""
from __future__ import annotations

from imgui_bundle import imgui

from ...plugins import Param

SLIDER_INT_RANGE = 32


def _clamp(param: Param, value):
    if param.min is not None:
        value = max(value, type(value)(param.min))
    if param.max is not None:
        value = min(value, type(value)(param.max))
    return value


def param_widget(param: Param, value, label: str | None = None) -> tuple[bool, object]:
    """Draw the widget; (changed, new value)."""
    label = label or param.name
    if param.type == "bool":
        changed, value = imgui.checkbox(label, bool(value))
    elif param.type == "int":
        bounded = param.min is not None and param.max is not None
        if bounded and param.max - param.min <= SLIDER_INT_RANGE:
            changed, value = imgui.slider_int(label, int(value), int(param.min), int(param.max))
        else:
            changed, value = imgui.input_int(label, int(value))
    elif param.type == "float":
        if param.min is not None and param.max is not None:
            changed, value = imgui.slider_float(label, float(value), float(param.min), float(param.max))
        else:
            speed = max(abs(float(value)), 1.0) * 0.01
            changed, value = imgui.drag_float(label, float(value), speed)
    elif param.type == "color":
        changed, value = imgui.color_edit3(label, [float(v) for v in value], imgui.ColorEditFlags_.float)
    else:  # a manifest type this GUI does not know: show it, read-only
        imgui.text(f"{label} = {value!r}")
        changed = False
    if param.help:
        imgui.set_item_tooltip(param.help)
    if changed and param.type in ("int", "float"):
        value = _clamp(param, value)
    return changed, value
