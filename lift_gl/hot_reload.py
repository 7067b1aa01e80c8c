"""Hot reload (Renderer.reload): the plugin recompiled when its files change, the last good
program rendering on while an edit does not compile.

A broken edit (manifest or shader) raises its PluginError or ShaderError, which names the file
and line; the renderer keeps its passes and `reload_error` keeps the error until an edit
compiles. The watcher sees the same broken files once, not on every call.
"""
from __future__ import annotations

from .errors import LiftError
from .plugin_params import params_after_reload
from .plugins import load_manifest
from .watch import FileWatcher


def watched_files(r) -> set:
    """The plugin's own files and every file its program included (the library's too)."""
    return set(r.plugin.source_files()) | {f for f in r.trace.source.files if f.is_file()}


def new_watcher(r) -> FileWatcher:
    return FileWatcher(watched_files(r))


def reload(r, force: bool = False) -> bool:
    """Recompile r's plugin if any of its files changed since the last call (always with
    `force`). True when new programs replaced the old ones."""
    if not r.watcher.changed() and not force:
        return False
    try:
        plugin = load_manifest(r.plugin.folder)
        params = params_after_reload(plugin, r.scene, r.param_overrides)
        choices = r.resolve_choices(plugin, r.features, r.packed)   # its path steps or splats may have changed
        r.remake_plugin_passes(plugin, params, choices)
    except LiftError as exc:
        r.reload_error = exc
        raise
    r.plugin, r.params, r.choices, r.reload_error = plugin, params, choices, None
    r.samples_per_frame = r.samples_per_frame_asked or (1 if plugin.primary == "gbuffer" else 4)
    r.watcher.watch(watched_files(r))
    return True
