"""A plugin's parameter values: its manifest's defaults, the scene's path length, the caller's
settings, parsed and range-checked by the manifest (lift_gl/plugins.py)."""
from __future__ import annotations

from .errors import LiftError, PluginError
from .plugins import Plugin


def resolve_params(plugin: Plugin, scene, overrides: dict) -> dict:
    """Every parameter's value: the defaults, max_depth from the scene, then `overrides`."""
    values = plugin.defaults()
    if "max_depth" in plugin.params and scene.max_depth is not None:
        values["max_depth"] = plugin.params["max_depth"].parse(int(scene.max_depth))
    for name, value in overrides.items():
        if name not in plugin.params:
            raise PluginError(f"plugin {plugin.name!r} has no parameter {name!r} "
                              f"(it has: {', '.join(plugin.params) or 'none'})", plugin.manifest)
        values[name] = plugin.params[name].parse(value)
    return values


def params_after_reload(plugin: Plugin, scene, overrides: dict) -> dict:
    """A reloaded manifest's values: its defaults, with the caller's settings where they still
    apply (a parameter gone, or whose new type or range rejects the value, takes the default)."""
    kept = {}
    for name, value in overrides.items():
        try:
            kept[name] = resolve_params(plugin, scene, {name: value})[name]
        except LiftError:
            pass
    return {**resolve_params(plugin, scene, {}), **kept}
