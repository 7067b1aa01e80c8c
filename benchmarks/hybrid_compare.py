"""`lift-gl compare` of `hybrid` (indirect light at 1/2 and 1/4 resolution) against `pt` on
two scenes, for docs/teaching.md (hybrid mode's compare report):

    python benchmarks/hybrid_compare.py [--shared ../shared] [--out docs/teaching] [--time 16] [--seeds 2]

1. `scenes/cornell.toml` (glass sphere, rough gold box): where hybrid's filter blurs
   caustics, reflections and refractions.
2. Lift's `cornell-box` (pbrt-v3, all diffuse): where the filter has the least to blur.

Both at 96x96 against a long `pt` render (`--ref-spp`, cached by `lift-gl compare`): hybrid
is biased by design, and the question is how its error against time compares with pt's
converging one, not which of two renderers' conventions it matches (so not Tungsten's
reference). Writes OUT/compare-hybrid-SCENE/ (report.md, convergence plot, contact sheet
reduced to 256 colours, metrics.csv; the linear EXRs are not kept).
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from PIL import Image

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
from lift_gl.cli import main as lift_gl  # noqa: E402


def scrub_paths(folder: Path, replacements: dict[str, str]) -> None:
    """The report names the scene and reference files: keep this machine's folders out."""
    for name in ("report.md", "summary.json"):
        path = folder / name
        if path.exists():
            text = path.read_text()
            for old, new in replacements.items():
                text = text.replace(old, new)
            path.write_text(text)


def shrink_outputs(out: Path) -> None:
    shutil.rmtree(out / "images", ignore_errors=True)  # linear EXRs: large, and remade by this script
    # Noisy images compress badly: a 256-colour palette keeps the committed PNG small.
    sheet = Image.open(out / "contact_sheet.png").convert("RGB")
    sheet.quantize(256, method=Image.Quantize.MEDIANCUT).save(out / "contact_sheet.png", optimize=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shared", type=Path, default=REPO.parent / "shared")
    ap.add_argument("--out", type=Path, default=REPO / "docs" / "teaching")
    ap.add_argument("--time", type=float, default=16.0, help="render seconds per compare run")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--ref-spp", type=int, default=2048)
    ap.add_argument("--size", default="96x96")
    args = ap.parse_args()
    scenes = {"cornell-glass-gold": REPO / "scenes" / "cornell.toml",
              "lift-cornell-box": args.shared / "scenes_lift" / "cornell-box" / "scene.pbrt"}
    for name, scene in scenes.items():
        out = args.out / f"compare-hybrid-{name}"
        code = lift_gl(["compare", str(scene), "--integrators", "pt,hybrid,hybrid:indirect_scale=4",
                        "--time", str(args.time), "--seeds", str(args.seeds), "--size", args.size,
                        "--ref-spp", str(args.ref_spp), "--out", str(out)])
        if code:
            return code
        shrink_outputs(out)
        scrub_paths(out, {str(REPO) + "/": "", str(args.shared.resolve()): "../shared", str(args.shared): "../shared"})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
