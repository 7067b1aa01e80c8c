"""A strip of pt's bounces, one image each, and the full render they add up to.

    .venv/bin/python scripts/bounce_strip.py [--scene scenes/cornell.toml] [--size 128] [--spp 256]
                                             [--out docs/teaching/cornell-bounces.png]

Tiles: bounce 0 (emitters seen directly), 1 (direct light), 2, 3, 4, bounces 5..max_depth
(min_bounce=5), and the full image. Every tile is rendered with the same seed, so the paths
are the same and the tiles add up to the full image to float rounding: the script checks
that and prints the largest difference. All tiles share one exposure (the full image's),
so the falling brightness of later bounces is what it is.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from lift_gl import load_scene
from lift_gl.renderer import Renderer
from lift_gl.tonemap import to_srgb8

LABEL_HEIGHT = 18


def render(scene, size, spp, seed, **params) -> np.ndarray:
    r = Renderer(scene, size=(size, size), seed=seed, params=params)
    image = r.render(spp=spp)
    if r.stats.dropped_samples:
        raise SystemExit(f"{params}: {r.stats.dropped_samples} samples dropped as NaN/Inf")
    r.release()
    return image


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", default="scenes/cornell.toml")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--exposure", type=float, default=0.0)
    p.add_argument("--out", default="docs/teaching/cornell-bounces.png")
    args = p.parse_args(argv)

    scene = load_scene(args.scene)
    depth = scene.max_depth
    tiles = [(f"bounce {k}", render(scene, args.size, args.spp, args.seed, only_bounce=k)) for k in range(5)]
    tiles.append((f"bounces 5..{depth}", render(scene, args.size, args.spp, args.seed, min_bounce=5)))
    full = render(scene, args.size, args.spp, args.seed)
    total = np.sum([image.astype(np.float64) for _, image in tiles], axis=0)
    difference = np.abs(total - full).max()
    relative = (np.abs(total - full) / np.maximum(full, 1e-3)).max()
    print(f"sum of the {len(tiles)} tiles vs the full image: max |difference| {difference:.3g} "
          f"(relative {relative:.3g})")
    tiles.append(("full = sum", full))

    s = args.size
    strip = Image.new("RGB", (s * len(tiles), s + LABEL_HEIGHT), (20, 20, 20))
    draw = ImageDraw.Draw(strip)
    for i, (label, image) in enumerate(tiles):
        strip.paste(Image.fromarray(to_srgb8(image, args.exposure)), (i * s, LABEL_HEIGHT))
        draw.text((i * s + 4, 3), label, fill=(230, 230, 230))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    strip.save(out)
    print(f"wrote {out} ({len(tiles)} tiles of {s}x{s}, {args.spp} spp each)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
