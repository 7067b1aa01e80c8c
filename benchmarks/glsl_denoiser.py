"""The GLSL denoiser (lift_gl/denoise/glsl_net.py) against onnxruntime: time per frame and the
largest difference, at 256x256, 1280x720 and 1920x1080, per conv variant, and with
--per-dispatch each dispatch's time and a cost model's prediction (lift_gl/denoise/cost_model.py).

    python benchmarks/glsl_denoiser.py [--models shipped,random-unet,random-rt] [--sizes 256x256,1920x1080]
                                       [--variants 1x8,2x4] [--repeat 3]
                                       [--per-dispatch] [--calibrate shipped] [--no-onnxruntime] [--out FILE.json]

Models: `shipped` is assets/denoiser/lift_unet.onnx (skipped where absent); random-weight
networks (lift_gl/denoise/random_unet.py): `random-unet` the shipped model's graph (encoder
32, 48, 64, 80, bottleneck 80, the colour curve in and out), `random-rt` the real-time model's
(lift_gl/denoise/train/model.py "rt": a 2x2 stride-2 conv in, 32, 48, 64 at 1/2 .. 1/8, 64 at
1/16, a 2x2 stride-2 ConvTranspose out), `random-rt-temporal` the same with the 13-channel
temporal input, `random-small` (16, 32, 48, 64; 80) and `random-oidn` (32, 48, 64, 80; 96)
without the curve; a path ending in .onnx: that model. Random weights time the same as
trained ones (the same dispatches and memory traffic). The input is a random tensor (colours
>= 0, albedo in [0, 1], normals in [-1, 1]).

GLSL times are of run() only (the input already in its texture, as in the viewer): wall
clock between glFinish calls on llvmpipe, GL timer queries on a GPU. onnxruntime (CPU
provider) runs the same padded input in the same process, interleaved with the GLSL runs,
as the baseline; `--variants` compares the conv kernel's variants in the same interleaved way:
BxP = B output layers (of 4 channels) times P pixels of a row per invocation (default: the
context's, glsl_net.default_shape). `--per-dispatch` also times each dispatch alone (a timer
around each: their sum exceeds the whole run's by the overlap it forbids), fits the cost
model to the `--calibrate` model's dispatches at the largest size, per variant, and prints
every model's predicted time against its measured one. Headless (EGL), so it runs on the
GPU machine as it does here.
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
from lift_gl.denoise.cost_model import CostModel, step_costs  # noqa: E402
from lift_gl.denoise.glsl_net import GlslNet, default_shape  # noqa: E402
from lift_gl.gl.context import create_context, is_software  # noqa: E402
from lift_gl.passes.common import GpuTimer  # noqa: E402
from lift_gl.report.machine import describe_machine, machine_line  # noqa: E402

SHIPPED = REPO / "assets" / "denoiser" / "lift_unet.onnx"
# name: random_unet arguments
RANDOM_MODELS = {
    "random-small": dict(encoder=(16, 32, 48, 64), bottleneck=80),
    "random-oidn": dict(encoder=(32, 48, 64, 80), bottleneck=96),
    "random-unet": dict(encoder=(32, 48, 64, 80), bottleneck=80, colour_curve=True),
    "random-rt": dict(encoder=(24, 32, 48), bottleneck=48, arch="rt", colour_curve=True),
    "random-rt-temporal": dict(encoder=(24, 32, 48), bottleneck=48, arch="rt", colour_curve=True, in_channels=13),
}


def model_path(name: str, workdir: Path) -> Path | None:
    if name == "shipped":
        return SHIPPED if SHIPPED.is_file() else None
    if name.endswith(".onnx"):  # any model file
        return Path(name) if Path(name).is_file() else None
    import onnx

    from lift_gl.denoise.random_unet import random_unet

    path = workdir / f"{name}.onnx"
    onnx.save(random_unet(seed=0, **RANDOM_MODELS[name]), path)
    return path


def network_input(width: int, height: int, channels: int = 9, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.random((1, channels, height, width), dtype=np.float32)
    x[:, :3] *= 4.0
    x[:, 6:9] = 2.0 * x[:, 6:9] - 1.0
    if channels > 9:  # the previous colour and its validity
        x[:, 9:12] *= 4.0
        x[:, 12] = 1.0
    return x


def time_per_dispatch(ctx, net, repeat: int) -> list[float]:
    """The median over `repeat` runs of each dispatch's time (ms)."""
    runs = []
    for _ in range(repeat):
        timers = [GpuTimer(ctx, cpu_clock=is_software(ctx)) for _ in net.plan.steps]
        net.run(step_timers=timers)
        runs.append([t.last_ms for t in timers])
    return [float(v) for v in np.median(np.array(runs), axis=0)]


def warm_up(ctx, nets, seconds: float) -> None:
    """Run `nets` for `seconds` of wall clock (glFinish after each) before they are timed: a GPU
    that idled while the model was read and compiled may start it at a lower clock (an idle
    H200 reports 345 MHz, 1,980 under load; two rt networks of one graph once timed 8.3 and
    11.7 ms in one process, a ratio their weights cannot explain)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        for net in nets:
            net.run()
        ctx.finish()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="shipped,random-unet,random-rt,random-rt-temporal")
    parser.add_argument("--sizes", default="256x256,1280x720,1920x1080")
    parser.add_argument("--variants", default=None, help="conv variants BxP to compare, e.g. 1x8,2x4 "
                                                         "(default: the context's)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--warm-up-s", type=float, default=1.0,
                        help="run the networks this long before timing each model and size")
    parser.add_argument("--per-dispatch", action="store_true", help="time each dispatch and fit the cost model")
    parser.add_argument("--calibrate", default="shipped", help="the model the cost model is fitted to "
                                                                "(random-unet where the shipped one is absent)")
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
    variants = args.variants.split(",") if args.variants else ["{}x{}".format(*default_shape(ctx))]
    configs = variants
    label = {c: c for c in configs}
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
        nets = {c: GlslNet(ctx, path, out_block=int(c.split("x")[0]), pixels=int(c.split("x")[1])) for c in configs}
        input_name = session.get_inputs()[0].name if session else None
        any_net = nets[configs[0]]
        for width, height in sizes:
            x = network_input(width, height, any_net.input_channels)
            row = {"model": Path(name).name, "size": f"{width}x{height}", "dispatches": len(any_net.plan.steps),
                   "glsl_ms": {}, "glsl_ms_all": {}}
            multiple = any_net.multiple
            padded_size = (width + -width % multiple, height + -height % multiple)
            padded = np.pad(x, ((0, 0), (0, 0), (0, -height % multiple), (0, -width % multiple)), mode="edge")
            outputs = {}
            for c, net in nets.items():  # first run: allocation, shader compilation; kept for the difference
                t = time.perf_counter()
                outputs[c] = net.run_numpy(x)
                row.setdefault("first_run_s", {})[label[c]] = round(time.perf_counter() - t, 2)
            warm_up(ctx, list(nets.values()), args.warm_up_s)
            times = {c: [] for c in configs}
            ort_times = []
            for _ in range(args.repeat):  # interleaved: the load of this shared machine hits all alike
                for c, net in nets.items():
                    timer = GpuTimer(ctx, cpu_clock=is_software(ctx))
                    with timer:
                        net.run()
                    times[c].append(timer.last_ms)
                if session is not None:
                    t = time.perf_counter()
                    reference = session.run(None, {input_name: padded})[0][:, :, :height, :width]
                    ort_times.append((time.perf_counter() - t) * 1e3)
            for c in configs:
                row["glsl_ms"][label[c]] = round(float(np.median(times[c])), 3)
                row["glsl_ms_all"][label[c]] = [round(t, 3) for t in times[c]]
            if args.per_dispatch:
                row["dispatches_ms"] = {}
                for c, net in nets.items():
                    costs = step_costs(net, *padded_size)
                    ms = time_per_dispatch(ctx, net, args.repeat)
                    row["dispatches_ms"][label[c]] = [{**cost.as_dict(), "ms": round(t, 4)} for cost, t in zip(costs, ms)]
            if session is not None:
                row["onnxruntime_cpu_ms"] = round(float(np.median(ort_times)), 2)
                row["max_abs_diff"] = {label[c]: float(np.abs(outputs[c] - reference).max()) for c in configs}
                row["max_abs_output"] = float(np.abs(reference).max())
            results.append(row)
            line = f"{Path(name).name:18s} {width}x{height}: GLSL " + ", ".join(
                f"{label[c]}: {row['glsl_ms'][label[c]]:.2f} ms" for c in configs)
            if session is not None:
                line += (f" | onnxruntime CPU {row['onnxruntime_cpu_ms']:.1f} ms | max |GLSL - ort| "
                         + ", ".join(f"{row['max_abs_diff'][label[c]]:.2e}" for c in configs)
                         + f" (outputs up to {row['max_abs_output']:.3g})")
            print(line, flush=True)
        for net in nets.values():
            net.release()
    cost_models = predict(results, configs, label, args.calibrate) if args.per_dispatch else {}
    if args.out:
        Path(args.out).write_text(json.dumps({"machine": machine, "random_weights": "random-* models have random "
                                              "weights (timing only)", "cost_models": cost_models,
                                              "results": results}, indent=1))


def predict(results: list[dict], configs, label, calibrate: str) -> dict:
    """Fit the cost model per configuration on the calibration model's largest size; write
    each row's prediction into it and print predicted against measured."""
    names = {r["model"] for r in results}
    if calibrate not in names:
        calibrate = "random-unet" if "random-unet" in names else sorted(names)[0]
    largest = max((r for r in results if r["model"] == calibrate),
                  key=lambda r: np.prod([int(v) for v in r["size"].split("x")]))
    models = {}
    for c in configs:
        steps = largest["dispatches_ms"][label[c]]
        from lift_gl.denoise.cost_model import StepCost

        costs = [StepCost(s["kind"], s["output"], s["multiply_adds"], s["bytes"]) for s in steps]
        model = CostModel.fit(costs, [s["ms"] for s in steps])
        models[label[c]] = {**model.as_dict(), "calibrated_on": f"{calibrate} {largest['size']}"}
        print(f"cost model {label[c]} (fitted to {calibrate} {largest['size']}, {len(steps)} dispatches): "
              f"{model.launch_ms * 1e3:.1f} us a dispatch + {model.ms_per_gmac:.3f} ms per 10^9 multiply-adds "
              f"+ {model.ms_per_gb:.3f} ms per GB")
        for row in results:
            steps = row["dispatches_ms"][label[c]]
            costs = [StepCost(s["kind"], s["output"], s["multiply_adds"], s["bytes"]) for s in steps]
            predicted = model.predict_ms(costs)
            row.setdefault("predicted_ms", {})[label[c]] = round(predicted, 3)
            row.setdefault("dispatch_sum_ms", {})[label[c]] = round(sum(s["ms"] for s in steps), 3)
            print(f"  {row['model']:18s} {row['size']:>10s}: predicted {predicted:8.2f} ms, dispatches alone "
                  f"{row['dispatch_sum_ms'][label[c]]:8.2f} ms, whole run {row['glsl_ms'][label[c]]:8.2f} ms")
    return models


if __name__ == "__main__":
    main()
