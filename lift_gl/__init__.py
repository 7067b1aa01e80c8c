"""lift-gl: a hybrid raster + OpenGL-compute ray tracer for teaching and studying light transport."""
from __future__ import annotations

__version__ = "0.1.0"


def load_scene(path):
    """Load a scene file (.toml, .pbrt, .obj/.ply/.glb/.gltf) into a Scene."""
    from .scene.loader import load_scene as _load

    return _load(path)


def __getattr__(name):
    # Renderer pulls in moderngl: import it only when asked for.
    if name == "Renderer":
        from .renderer import Renderer

        return Renderer
    raise AttributeError(name)


__all__ = ["load_scene", "Renderer"]
