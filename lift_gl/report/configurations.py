"""What `lift-gl compare` compares: configurations of integrator, parameters and denoiser.

    --integrators pt,pt:max_depth=3,mine    a plugin name (or folder), then :NAME=VALUE settings
    --denoise off,final                     every configuration once per denoiser mode
    --denoiser atrous                       which denoiser the modes other than off use
    --set bdpt.max_depth=8                  a setting for every configuration of that plugin

A configuration's label is its spec as written (plus `+denoise=MODE` when not off, and the
denoiser's name when it is not the default, `+denoise=MODE:oidn`); labels name the curves, the
CSV rows and the image files. Denoised configurations are biased (lift_gl/denoise BIASED).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

from ..errors import LiftError

DENOISE_MODES = ("off", "final", "every")


@dataclass(frozen=True)
class Configuration:
    label: str
    integrator: str
    params: dict = field(default_factory=dict)  # NAME -> value as text (the plugin parses it)
    denoise: str = "off"
    denoiser: str = "auto"  # used when denoise is not off

    @property
    def file_stem(self) -> str:
        """The label made safe for a file name."""
        return re.sub(r"[^A-Za-z0-9._=+-]+", "_", self.label).strip("_") or "config"


def _split_list(text: str, what: str) -> list[str]:
    items = [item.strip() for item in text.split(",")]
    if not text.strip() or any(not item for item in items):
        raise LiftError(f"{what} expects a comma-separated list without empty items, got {text!r}")
    return items


def parse_spec(spec: str) -> tuple[str, dict]:
    """'pt:max_depth=3:rr_depth=2' -> ('pt', {'max_depth': '3', 'rr_depth': '2'})."""
    name, *settings = spec.split(":")
    params = {}
    for setting in settings:
        key, sep, value = setting.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise LiftError(f"integrator {spec!r}: settings are written NAME=VALUE after a colon, "
                            f"as in pt:max_depth=3, not {setting!r}")
        params[key.strip()] = value.strip()
    if not name.strip():
        raise LiftError(f"integrator {spec!r} has no plugin name")
    return name.strip(), params


def parse_configurations(integrators: str, denoise: str = "off", settings: dict | None = None,
                         denoiser: str = "auto") -> list[Configuration]:
    """The configurations to compare, in the order given. `settings` maps a plugin name to
    the --set values for it; a spec's own settings win over them."""
    modes = _split_list(denoise, "--denoise")
    for mode in modes:
        if mode not in DENOISE_MODES:
            raise LiftError(f"--denoise: unknown mode {mode!r}; choose among {', '.join(DENOISE_MODES)}")
    configs = []
    for spec in _split_list(integrators, "--integrators"):
        name, params = parse_spec(spec)
        merged = dict((settings or {}).get(name, {}), **params)
        for mode in modes:
            label = spec if mode == "off" else f"{spec}+denoise={mode}" + ("" if denoiser == "auto" else f":{denoiser}")
            configs.append(Configuration(label=label, integrator=name, params=merged, denoise=mode, denoiser=denoiser))
    labels = [c.label for c in configs]
    repeated = sorted({label for label in labels if labels.count(label) > 1})
    if repeated:
        raise LiftError(f"--integrators: {', '.join(repeated)} given more than once")
    return configs
