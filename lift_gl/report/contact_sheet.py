"""A contact sheet: the reference and each configuration's image at equal render time,
tone-mapped side by side, with each image's relative squared error as a heat map beneath."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..metrics import REL_MSE_EPS
from ..tonemap import to_srgb8

TILE_MIN, TILE_MAX = 128, 192  # longer side of a tile: small renders are enlarged by whole factors, large ones reduced
CAPTION = 44  # three lines of text under a tile


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: a fixed bitmap font
        return ImageFont.load_default()


def _tile(srgb8: np.ndarray):
    from PIL import Image

    h, w = srgb8.shape[:2]
    longer = max(h, w)
    scale = TILE_MAX / longer if longer > TILE_MAX else float(max(1, -(-TILE_MIN // longer)))
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    return Image.fromarray(srgb8).resize(size, Image.NEAREST if scale >= 1 else Image.BOX)


def error_map(image: np.ndarray, reference: np.ndarray, vmax: float) -> np.ndarray:
    """Per-pixel relative squared error (channel mean), log-scaled into a colour map; uint8."""
    from matplotlib import colormaps

    rel = np.mean((image.astype(np.float64) - reference) ** 2 / (reference.astype(np.float64) ** 2 + REL_MSE_EPS), axis=-1)
    lo = vmax * 1e-4
    t = np.clip(np.log(np.maximum(rel, lo) / lo) / np.log(vmax / lo), 0, 1)
    return (colormaps["magma"](t)[..., :3] * 255 + 0.5).astype(np.uint8)


def contact_sheet(reference: np.ndarray, entries: list[tuple[str, str, np.ndarray]], path: Path,
                  exposure: float = 0.0) -> Path:
    """entries: (title, subtitle, linear image) per configuration. Writes a PNG."""
    from PIL import Image, ImageDraw

    columns = [("reference", "", reference, None)]
    rels = [np.mean((img.astype(np.float64) - reference) ** 2 / (reference.astype(np.float64) ** 2 + REL_MSE_EPS), -1)
            for _, _, img in entries]
    vmax = max([float(np.percentile(r, 99.5)) for r in rels] + [1e-6])
    for (title, subtitle, image) in entries:
        columns.append((title, subtitle, image, error_map(image, reference, vmax)))
    first = _tile(to_srgb8(reference, exposure))
    tw, th = first.size
    rows = 2 if entries else 1
    sheet = Image.new("RGB", (len(columns) * (tw + 4) + 4, rows * (th + CAPTION + 4) + 4), "white")
    draw = ImageDraw.Draw(sheet)
    font = _font(11)
    for i, (title, subtitle, image, heat) in enumerate(columns):
        x = 4 + i * (tw + 4)
        sheet.paste(_tile(to_srgb8(image, exposure)), (x, 4))
        draw.text((x, th + 6), title, fill="black", font=font)
        draw.multiline_text((x, th + 19), subtitle, fill=(70, 70, 70), font=font, spacing=2)
        if heat is not None:
            y = 4 + th + CAPTION + 4
            sheet.paste(_tile(heat), (x, y))
            draw.text((x, y + th + 2), "rel. squared error", fill=(70, 70, 70), font=font)
        elif rows == 2:
            y = 4 + th + CAPTION + 4
            draw.text((x, y + 4), f"error maps,\nlog scale:\n{vmax * 1e-4:.1e} dark\nto {vmax:.1e} light",
                      fill="black", font=font)
    path = Path(path)
    with atomic_path(path) as tmp:
        sheet.save(tmp, optimize=True)
    return path
