"""The renderer's denoise step with denoiser="glsl": the GPU road (passes/net_denoise.py: input
tensor, network and remodulation on textures) against the readback road (the mean, guides
and variance read back, model_io in numpy, GlslNet.run_numpy, the result uploaded), on one
Renderer's accumulation and G-buffer, runs interleaved, median per road and their ratio.

    python benchmarks/net_denoise.py [--sizes 96x96,256x256] [--repeat 5] [--out FILE.json]

Wall clock of DenoisePass.run / _run_numpy between glFinish calls. Both include the network,
which dominates on llvmpipe; the `_around` columns time the same roads with GlslNet.run
replaced by nothing (in the same interleaved loop): what each road costs around the network
(GPU: three small dispatches; readback: readback, numpy preparation, upload).
"""
from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

from lift_gl.frame_settings import DenoiseSettings
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml"


def timed(ctx, fn) -> float:
    ctx.finish()
    start = time.perf_counter()
    fn()
    ctx.finish()
    return time.perf_counter() - start


def measure(size, repeat: int) -> dict:
    r = Renderer(load_scene(SCENE), size=size, seed=1, denoise=DenoiseSettings("final", "glsl"))
    try:
        r.render(spp=1, final=False)
        gbuffer = r._guides()
        net = r.denoise_pass.net.net

        def without_network(fn):
            def run():
                net.run = lambda: None  # an instance attribute hides the method
                try:
                    fn()
                finally:
                    del net.run
            return run
        gpu_road = lambda: r.denoise_pass.run(r.accumulate, gbuffer)  # noqa: E731
        readback_road = lambda: r.denoise_pass._run_numpy(r.accumulate, gbuffer)  # noqa: E731
        roads = {"gpu": gpu_road, "readback": readback_road,
                 "gpu_around": without_network(gpu_road), "readback_around": without_network(readback_road)}
        for fn in roads.values():  # warm-up: shader compiles, textures
            timed(r.ctx, fn)
        times = {name: [] for name in roads}
        for _ in range(repeat):
            for name, fn in roads.items():
                times[name].append(timed(r.ctx, fn))
        r._guides_done()
        median = {name: statistics.median(t) for name, t in times.items()}
        return {"size": f"{size[0]}x{size[1]}", **{f"{name}_s": m for name, m in median.items()},
                "readback_over_gpu": median["readback"] / median["gpu"],
                "around_readback_over_gpu": median["readback_around"] / median["gpu_around"],
                "runs": times, "renderer": r.ctx.info["GL_RENDERER"]}
    finally:
        r.release()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="96x96,256x256")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out")
    args = parser.parse_args(argv)
    rows = [measure(tuple(int(v) for v in s.split("x")), args.repeat) for s in args.sizes.split(",")]
    print(f"{'size':>9} {'gpu road':>10} {'readback':>10} {'ratio':>6} | around the network: "
          f"{'gpu':>8} {'readback':>9} {'ratio':>6}   ({rows[0]['renderer']})")
    for row in rows:
        print(f"{row['size']:>9} {row['gpu_s'] * 1e3:8.1f}ms {row['readback_s'] * 1e3:8.1f}ms "
              f"{row['readback_over_gpu']:6.2f} | {'':19}{row['gpu_around_s'] * 1e3:6.2f}ms "
              f"{row['readback_around_s'] * 1e3:7.2f}ms {row['around_readback_over_gpu']:6.1f}")
    if args.out:
        Path(args.out).write_text(json.dumps({"machine": platform.processor() or platform.machine(),
                                              "repeat": args.repeat, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
