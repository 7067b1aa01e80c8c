"""lift-gl in Jupyter (docs/notebooks.md).

| module      | concern                                                                  |
| ----------- | ------------------------------------------------------------------------ |
| display.py  | images as PNG for the notebook (`Image`, `show`, `Renderer._repr_png_`)  |
| comparison.py | `compare(...)`: runs `lift-gl compare`, shows its plot and table inline  |
| widget.py   | `Viewer`: a progressive render in the browser, orbit and zoom by mouse   |
| render_thread.py | the widget's renderer, on a thread that owns its GL context         |

Nothing here is imported by `import lift_gl`; anywidget loads only when a Viewer is made.
"""
from __future__ import annotations


def __getattr__(name):
    if name in ("Image", "show", "png_bytes"):
        from . import display

        return getattr(display, name)
    if name in ("compare", "Comparison"):
        from . import comparison

        return getattr(comparison, name)
    if name == "Viewer":
        from .widget import Viewer

        return Viewer
    raise AttributeError(name)


__all__ = ["Image", "show", "png_bytes", "compare", "Comparison", "Viewer"]
