"""The GLSL denoiser (lift_gl/denoise/glsl_net.py) against onnxruntime: time per frame and the
largest difference, at 256x256, 1280x720 and 1920x1080.

    python benchmarks/glsl_denoiser.py [--models shipped,random-small,random-oidn] [--sizes 256x256,1280x720,1920x1080]
                                       [--variants 1x8,2x4] [--repeat 3] [--no-onnxruntime] [--out FILE.json]

Models: `shipped` is assets/denoiser/lift_unet.onnx (skipped where absent); `random-small` a
random-weight U-Net of the shipped model's shape (encoder 16, 32, 48, 64, bottleneck 80);
`random-oidn` one of OIDN's widths (32, 48, 64, 80, bottleneck 96); a path ending in .onnx:
that model. Random weights time the
same as trained ones (the same dispatches and memory traffic). The input is a random
(1, 9, H, W) tensor (colour >= 0, albedo in [0, 1], normals in [-1, 1]).

GLSL times are of run() only (the input already in its texture, as in the viewer): wall
clock between glFinish calls on llvmpipe, GL timer queries on a GPU. onnxruntime (CPU
provider) runs the same padded input in the same process, interleaved with the GLSL runs,
as the baseline; `--variants` compares the conv kernel's variants in the same interleaved way:
BxP = B output layers (of 4 channels) times P pixels of a row per invocation. Headless (EGL), so it runs on the GPU
machine as it does here.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
from lift_gl.denoise.glsl_net import GlslNet  # noqa: E402
from lift_gl.gl.context import create_context, is_software  # noqa: E402
from lift_gl.passes.common import GpuTimer  # noqa: E402
from lift_gl.report.machine import describe_machine, machine_line  # noqa: E402

SHIPPED = REPO / "assets" / "denoiser" / "lift_unet.onnx"
RANDOM_SHAPES = {"random-small": ((16, 32, 48, 64), 80), "random-oidn": ((32, 48, 64, 80), 96)}


def model_path(name: str, workdir: Path) -> Path | None:
    if name == "shipped":
        return SHIPPED if SHIPPED.is_file() else None
    if name.endswith(".onnx"):  # any model file
        return Path(name) if Path(name).is_file() else None
    import onnx

    from lift_gl.denoise.random_unet import random_unet

    encoder, bottleneck = RANDOM_SHAPES[name]
    path = workdir / f"{name}.onnx"
    onnx.save(random_unet(encoder=encoder, bottleneck=bottleneck, seed=0), path)
    return path


def network_input(width: int, height: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.random((1, 9, height, width), dtype=np.float32)
    x[:, :3] *= 4.0
    x[:, 6:] = 2.0 * x[:, 6:] - 1.0
    return x


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="shipped,random-small,random-oidn")
    parser.add_argument("--sizes", default="256x256,1280x720,1920x1080")
    parser.add_argument("--variants", default="1x8", help="conv variants BxP to compare, e.g. 1x1,2x1,1x8,2x4")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-onnxruntime", action="store_true")
    parser.add_argument("--workdir", default="/tmp/glsl_denoiser_bench")
    parser.add_argument("--out", help="write the results as JSON")
    args = parser.parse_args()

    ctx = create_context()
    machine = describe_machine(ctx)
    print(machine_line(machine))
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    sizes = [tuple(int(v) for v in s.split("x")) for s in args.sizes.split(",")]
    blocks = args.variants.split(",")
    results = []
    for name in args.models.split(","):
        path = model_path(name, workdir)
        if path is None:
            print(f"{name}: {SHIPPED} is absent, skipped")
            continue
        session = None
        if not args.no_onnxruntime:
            import onnxruntime as ort

            session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        nets = {b: GlslNet(ctx, path, out_block=int(b.split("x")[0]), pixels=int(b.split("x")[1])) for b in blocks}
        input_name = session.get_inputs()[0].name if session else None
        for width, height in sizes:
            x = network_input(width, height)
            row = {"model": Path(name).name, "size": f"{width}x{height}", "glsl_ms": {}, "glsl_ms_all": {}}
            multiple = nets[blocks[0]].multiple
            padded = np.pad(x, ((0, 0), (0, 0), (0, -height % multiple), (0, -width % multiple)), mode="edge")
            outputs = {}
            for b, net in nets.items():  # first run: allocation, shader compilation; kept for the difference
                t = time.perf_counter()
                outputs[b] = net.run_numpy(x)
                row.setdefault("first_run_s", {})[b] = round(time.perf_counter() - t, 2)
            times = {b: [] for b in blocks}
            ort_times = []
            for _ in range(args.repeat):  # interleaved: the load of this shared machine hits all alike
                for b, net in nets.items():
                    timer = GpuTimer(ctx, cpu_clock=is_software(ctx))
                    with timer:
                        net.run()
                    times[b].append(timer.last_ms)
                if session is not None:
                    t = time.perf_counter()
                    reference = session.run(None, {input_name: padded})[0][:, :, :height, :width]
                    ort_times.append((time.perf_counter() - t) * 1e3)
            for b in blocks:
                row["glsl_ms"][b] = round(float(np.median(times[b])), 2)
                row["glsl_ms_all"][b] = [round(t, 2) for t in times[b]]
            if session is not None:
                row["onnxruntime_cpu_ms"] = round(float(np.median(ort_times)), 2)
                row["max_abs_diff"] = {b: float(np.abs(outputs[b] - reference).max()) for b in blocks}
                row["max_abs_output"] = float(np.abs(reference).max())
            results.append(row)
            line = f"{Path(name).name:13s} {width}x{height}: GLSL " + ", ".join(
                f"{b}: {row['glsl_ms'][b]:.1f} ms" for b in blocks)
            if session is not None:
                line += (f" | onnxruntime CPU {row['onnxruntime_cpu_ms']:.1f} ms | max |GLSL - ort| "
                         + ", ".join(f"{row['max_abs_diff'][b]:.2e}" for b in blocks)
                         + f" (outputs up to {row['max_abs_output']:.3g})")
            print(line, flush=True)
        for net in nets.values():
            net.release()
    if args.out:
        Path(args.out).write_text(json.dumps({"machine": machine, "random_weights": "random-* models have random "
                                              "weights (timing only)", "results": results}, indent=1))


if __name__ == "__main__":
    main()
