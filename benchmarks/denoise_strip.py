"""A strip of scenes/cornell.toml: noisy pt at N spp, the à-trous denoiser on it (and OIDN when
pyoidn is installed), and a pt reference of many spp; relMSE and SSIM against the reference
under each image. The noisy and denoised images are the same render (Renderer.noisy_image()
and image()), so the strip shows exactly what the filter did.

    python benchmarks/denoise_strip.py [--spp 4] [--ref-spp 256] [--size 256] \\
        [--out docs/denoiser/cornell_atrous_4spp.png]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from lift_gl import metrics
from lift_gl.frame_settings import DenoiseSettings
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene
from lift_gl.tonemap import to_srgb8

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml"


def strip(columns, path: Path) -> None:
    from PIL import Image, ImageDraw, ImageFont

    h, w = columns[0][2].shape[:2]
    caption = 34
    sheet = Image.new("RGB", (len(columns) * (w + 4) + 4, h + caption + 8), "white")
    draw = ImageDraw.Draw(sheet)
    try:
        font = ImageFont.load_default(size=12)
    except TypeError:
        font = ImageFont.load_default()
    for i, (title, subtitle, image) in enumerate(columns):
        x = 4 + i * (w + 4)
        sheet.paste(Image.fromarray(to_srgb8(image)), (x, 4))
        draw.text((x, h + 6), title, fill="black", font=font)
        draw.text((x, h + 21), subtitle, fill=(70, 70, 70), font=font)
    path.parent.mkdir(parents=True, exist_ok=True)
    # 256 colours, dithered (no banding in smooth walls): a third of the RGB file, for the repo.
    palette = sheet.quantize(256)
    sheet.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG).save(path, optimize=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--ref-spp", type=int, default=256)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--out", type=Path, default=Path("docs/denoiser/cornell_atrous_4spp.png"))
    args = parser.parse_args()
    scene = load_scene(SCENE)
    size = (args.size, args.size)
    ref_renderer = Renderer(scene, size=size, seed=1000)
    reference = ref_renderer.render(spp=args.ref_spp)
    ref_renderer.release()

    def caption(image):
        return f"relMSE {metrics.rel_mse(image, reference):.4f}, SSIM {metrics.ssim(image, reference):.3f}"

    r = Renderer(scene, size=size, seed=1, denoise="final")
    start = time.perf_counter()
    denoised = r.render(spp=args.spp)
    print(f"{args.spp} spp + à-trous: {time.perf_counter() - start:.2f} s, {r.stats.summary()}")
    noisy = r.noisy_image()
    columns = [(f"pt, {args.spp} spp", caption(noisy), noisy), ("a-trous on it (atrous)", caption(denoised), denoised)]
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        print("pyoidn is not installed: no OIDN column")
    else:
        oidn = Renderer(scene, size=size, seed=1, denoise=DenoiseSettings("final", "oidn"))
        image = oidn.render(spp=args.spp)
        columns.append(("OIDN on it", caption(image), image))
        oidn.release()
    columns.append((f"pt, {args.ref_spp} spp (reference)", "", reference))
    r.release()
    for title, text, _ in columns:
        print(f"{title}: {text}")
    strip(columns, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
