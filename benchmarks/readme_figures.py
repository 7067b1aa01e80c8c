"""The figures in the README, made by the commands themselves:

    python benchmarks/readme_figures.py [--shared ../shared] [--out docs] [--time 20] [--seeds 3]

1. `lift-gl compare` on Lift's Cornell box (pbrt-v3, 128x128) against Tungsten's reference:
   pt, bdpt, and pt with max_depth=3 (biased: light after three bounces is missing); equal
   time, with the checkpoint overhead measured -> OUT/compare-cornell-box/ (report.md, plot, contact sheet
   reduced to 256 colours, metrics.csv; the linear EXRs are not kept).
2. `lift-gl bench` on the repository's scenes and the pbrt Cornell box at 64, 128 and 256
   pixels -> OUT/bench.json and OUT/bench.md.
The denoiser has no `compare` mode yet (`--denoise` says so); when it has, add it here.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
from hybrid_compare import scrub_paths, shrink_outputs  # noqa: E402  (this folder)
from lift_gl.cli import main as lift_gl  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shared", type=Path, default=REPO.parent / "shared")
    ap.add_argument("--out", type=Path, default=REPO / "docs")
    ap.add_argument("--time", type=float, default=20.0, help="render seconds per compare run")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--skip-compare", action="store_true")
    ap.add_argument("--skip-bench", action="store_true")
    args = ap.parse_args()
    scene = args.shared / "scenes_lift" / "cornell-box" / "scene.pbrt"
    if not args.skip_compare:
        out = args.out / "compare-cornell-box"
        code = lift_gl(["compare", str(scene), "--integrators", "pt,bdpt,pt:max_depth=3",
                        "--time", str(args.time), "--seeds", str(args.seeds), "--size", "128x128",
                        "--ref", str(args.shared / "refs" / "lift" / "cornell-box.exr"),
                        "--measure-overhead", "--out", str(out)])
        if code:
            return code
        shrink_outputs(out)
        scrub_paths(out, {str(args.shared.resolve()): "../shared", str(args.shared): "../shared"})
    if not args.skip_bench:
        text = io.StringIO()
        with contextlib.redirect_stdout(text):
            code = lift_gl(["bench", str(REPO / "scenes" / "furnace.toml"), str(REPO / "scenes" / "cornell.toml"),
                            str(scene), "--sizes", "64x64,128x128,256x256", "--frames", "8", "--repeat", "3",
                            "--json", str(args.out / "bench.json")])
        print(text.getvalue())
        (args.out / "bench.md").write_text(text.getvalue())
        if code:
            return code
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
