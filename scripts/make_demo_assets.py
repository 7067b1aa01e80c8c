"""Make the small images that scenes/showcase.toml uses (committed; rerun to regenerate).

    python scripts/make_demo_assets.py

- assets/textures/checker.png: 128x128 sRGB, 8x8 tiles of two warm greys with a thin line.
- assets/env/sky.exr: a 128x64 latitude-longitude sky (Mitsuba's mapping, +y up, u = 0 at
  -z): a blue gradient above the horizon, a dim brown ground below, and a sun of radius 3
  degrees, 35 degrees above the horizon towards the map's -z (SUN).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SUN = np.array([0.0, np.sin(np.radians(35)), -np.cos(np.radians(35))])  # map frame, towards the sun


def checker() -> np.ndarray:
    n, tiles = 128, 8
    y, x = np.mgrid[0:n, 0:n]
    tile = ((x // (n // tiles)) + (y // (n // tiles))) % 2
    img = np.where(tile[..., None] == 1, [196, 178, 150], [92, 84, 76]).astype(np.uint8)
    line = (x % (n // tiles) == 0) | (y % (n // tiles) == 0)
    img[line] = (40, 36, 32)
    return img


def sky() -> np.ndarray:
    h, w = 64, 128
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    theta, phi = np.pi * v[:, None], 2 * np.pi * u[None, :]
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta) + 0 * phi, -np.sin(theta) * np.cos(phi)], -1)
    up = np.clip(d[..., 1], 0, 1)[..., None]
    img = np.where(d[..., 1:2] > 0, (1 - up) * [0.9, 1.0, 1.1] + up * [0.25, 0.45, 0.9],
                   [0.25, 0.2, 0.15])
    cos_sun = d @ SUN
    img = img + (cos_sun > np.cos(np.radians(3)))[..., None] * np.array([800.0, 700.0, 550.0])
    return img.astype(np.float32)


def main() -> None:
    from PIL import Image

    from lift_gl.image_io import write_image
    Image.fromarray(checker()).save(ROOT / "assets" / "textures" / "checker.png", optimize=True)
    write_image(ROOT / "assets" / "env" / "sky.exr", sky(), half=True)


if __name__ == "__main__":
    main()
