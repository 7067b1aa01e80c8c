"""The renderer's $LIFT_GL_* switches (BVH layout, stack, G-buffer, wavefront...): one reader
for all of them, so that each takes its values and reports a bad one the same way."""
from __future__ import annotations

import os

from .errors import LiftError


def env_choice(var: str, choices: tuple[str, ...], value=None) -> str:
    """`value`, else $var, else auto, lower-cased: one of `choices` or "auto" (unset or empty:
    "auto"); else one error naming the variable."""
    if value is None:
        value = os.environ.get(var, "auto")
    text = str(value).strip().lower() or "auto"
    if text != "auto" and text not in choices:
        raise LiftError(f"${var} must be {', '.join(choices)} or auto, not {value!r}")
    return text
