"""Draws the renderer's display texture (already tone-mapped sRGB, RGBA8) into the window.

No read-back: one textured quad, nearest-neighbour so that a render pixel stays a visible
block when the render resolution is lower than the window's. The split view draws two
textures with a divider between them. The image keeps its aspect ratio (letterboxed in
the area the docked panels leave).
"""
from __future__ import annotations

import math

import moderngl
import numpy as np

VERTEX = """
#version 330
out vec2 v_uv;
void main() {
    // One triangle covering the viewport; uv 0..1 on the visible part.
    vec2 p = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1)) - 1.0;
    v_uv = p * 0.5 + 0.5;
    gl_Position = vec4(p, 0.0, 1.0);
}
"""

FRAGMENT = """
#version 330
uniform sampler2D u_left;
uniform sampler2D u_right;
uniform float u_split;       // < 0: no split view; else the divider, in uv.x
uniform float u_divider_uv;  // half the divider's width, in uv.x
in vec2 v_uv;
out vec4 f_color;
void main() {
    if (u_split < 0.0 || v_uv.x < u_split - u_divider_uv) {
        f_color = vec4(texture(u_left, v_uv).rgb, 1.0);
    } else if (v_uv.x > u_split + u_divider_uv) {
        f_color = vec4(texture(u_right, v_uv).rgb, 1.0);
    } else {
        f_color = vec4(1.0, 0.85, 0.2, 1.0);  // the divider
    }
}
"""


def fit_rect(image_size, area_size, origin=(0, 0)) -> tuple[int, int, int, int]:
    """(x, y, w, h) in window pixels, y from the top: the largest rectangle of the image's
    aspect ratio centred in the area (of area_size, its top left corner at origin). Equal
    aspect ratios fill the area exactly. An enlargement a little above a whole number k is
    taken down to k when that gives up less than one render pixel's block: every render pixel
    is then k x k window pixels, not a mix of k and k + 1."""
    iw, ih = image_size
    ww, wh = area_size
    scale = min(ww / iw, wh / ih)
    whole = math.floor(scale)
    if whole >= 1 and (scale - whole) * max(iw, ih) < whole:
        scale = whole
    w, h = min(ww, round(iw * scale)), min(wh, round(ih * scale))
    return origin[0] + (ww - w) // 2, origin[1] + (wh - h) // 2, w, h


def window_to_pixel(point, rect, image_size) -> tuple[int, int] | None:
    """The render pixel (x, y from the top left) under a window point, or None outside."""
    x, y = point
    rx, ry, rw, rh = rect
    if not (rx <= x < rx + rw and ry <= y < ry + rh):
        return None
    return int((x - rx) * image_size[0] / rw), int((y - ry) * image_size[1] / rh)


class ImageView:
    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.program = ctx.program(vertex_shader=VERTEX, fragment_shader=FRAGMENT)
        self.vao = ctx.vertex_array(self.program, [])
        self.program["u_left"].value = 0
        self.program["u_right"].value = 1
        self._upload: moderngl.Texture | None = None  # for images that come from the CPU (AOVs)

    def upload(self, srgb8: np.ndarray) -> moderngl.Texture:
        """A texture of a uint8 (H, W, 3) display image, row 0 = top."""
        h, w = srgb8.shape[:2]
        if self._upload is None or self._upload.size != (w, h):
            if self._upload is not None:
                self._upload.release()
            self._upload = self.ctx.texture((w, h), 3, dtype="f1")
        self._upload.write(np.ascontiguousarray(srgb8[::-1]).tobytes())
        return self._upload

    @property
    def uploaded(self) -> moderngl.Texture | None:
        return self._upload

    def draw(self, framebuffer_size, rect, left: moderngl.Texture, right: moderngl.Texture | None = None,
             split: float = 0.5) -> None:
        """Draw into the bound framebuffer; rect (x, y, w, h) from the top left."""
        x, y, w, h = rect
        if w <= 0 or h <= 0:
            return
        self.ctx.viewport = (x, framebuffer_size[1] - y - h, w, h)
        self.ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST)
        for unit, texture in ((0, left), (1, right or left)):
            texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
            texture.use(unit)
        self.program["u_split"].value = float(split) if right is not None else -1.0
        self.program["u_divider_uv"].value = 1.0 / w
        self.vao.render(moderngl.TRIANGLES, vertices=3)
        self.ctx.viewport = (0, 0, *framebuffer_size)

    def release(self) -> None:
        for obj in (self.vao, self.program, self._upload):
            if obj is not None:
                obj.release()
