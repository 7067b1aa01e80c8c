"""U-Net-shaped ONNX models with random weights, built with onnx.helper (no torch): the test
and benchmark inputs of the GLSL executor (lift_gl/denoise/glsl_net.py).

    model = random_unet(encoder=(16, 32, 48, 64), bottleneck=80)   # an onnx.ModelProto
    onnx.save(model, "unet.onnx")

The shape follows OIDN's and the shipped denoiser's: per level a 3x3 conv + activation, a
2x2 pooling, a bottleneck, then per level an x2 upsampling, a skip (Concat, or Add where
`add_skips`), a 3x3 conv + activation, and a last conv to `out_channels`. Weights are He-
initialised (std sqrt(2 / fan_in)) so activations stay near 1 through the depth.
"""
from __future__ import annotations

import numpy as np


def random_unet(in_channels: int = 9, out_channels: int = 3, encoder=(16, 32, 48, 64), bottleneck: int = 80,
                pool: str = "MaxPool", upsample=("nearest", "asymmetric"), activation: str = "Relu",
                add_skips: bool = False, final_kernel: int = 3, seed: int = 0, opset: int = 17):
    """An onnx.ModelProto; `upsample` is (mode, coordinate_transformation_mode), or a list of
    those, one per decoder level (deepest first)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(seed)
    nodes, inits = [], []
    counter = iter(range(10 ** 6))

    def name(prefix):
        return f"{prefix}_{next(counter)}"

    def conv(x, cin, cout, k=3, act=True):
        w = name("w")
        b = name("b")
        inits.append(numpy_helper.from_array(
            (rng.standard_normal((cout, cin, k, k)) * np.sqrt(2.0 / (cin * k * k))).astype(np.float32), w))
        inits.append(numpy_helper.from_array((rng.standard_normal(cout) * 0.1).astype(np.float32), b))
        y = name("conv")
        p = k // 2
        nodes.append(helper.make_node("Conv", [x, w, b], [y], kernel_shape=[k, k], pads=[p, p, p, p]))
        if not act:
            return y
        z = name("act")
        if activation == "LeakyRelu":
            nodes.append(helper.make_node("LeakyRelu", [y], [z], alpha=0.1))
        else:
            nodes.append(helper.make_node(activation, [y], [z]))
        return z

    ups = [upsample] * len(encoder) if isinstance(upsample[0], str) else list(upsample)
    h, skips, prev = "input", [], in_channels
    for level, ch in enumerate(encoder):
        if level:
            p = name("pool")
            nodes.append(helper.make_node(pool, [h], [p], kernel_shape=[2, 2], strides=[2, 2]))
            h = p
        h = conv(h, prev, ch)
        skips.append((h, ch))
        prev = ch
    p = name("pool")
    nodes.append(helper.make_node(pool, [h], [p], kernel_shape=[2, 2], strides=[2, 2]))
    h = conv(conv(p, prev, bottleneck), bottleneck, bottleneck)
    prev = bottleneck
    for (skip, ch), (mode, transform) in zip(reversed(skips), ups):
        scales = name("scales")
        inits.append(numpy_helper.from_array(np.array([1, 1, 2, 2], np.float32), scales))
        u = name("up")
        nodes.append(helper.make_node("Resize", [h, "", scales], [u], mode=mode,
                                      coordinate_transformation_mode=transform,
                                      **({"nearest_mode": "floor"} if mode == "nearest" else {})))
        if add_skips:
            u = conv(u, prev, ch, k=1, act=False)  # match the skip's channels, then add
            s = name("sum")
            nodes.append(helper.make_node("Add", [u, skip], [s]))
            h = conv(s, ch, ch)
        else:
            c = name("cat")
            nodes.append(helper.make_node("Concat", [u, skip], [c], axis=1))
            h = conv(c, prev + ch, ch)
        prev = ch
    y = conv(h, prev, out_channels, k=final_kernel, act=False)
    nodes.append(helper.make_node("Identity", [y], ["output"]))
    graph = helper.make_graph(
        nodes, "random_unet",
        [helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, in_channels, "h", "w"])],
        [helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, out_channels, "h", "w"])], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)])
    model.ir_version = min(model.ir_version, 8)  # loadable by older onnxruntime builds too
    onnx.checker.check_model(model)
    return model


def multiply_adds_per_pixel(model) -> float:
    """Conv multiply-adds per input pixel, each level weighted by its share of the pixels
    (assumes one pooling between the levels, as random_unet builds)."""
    from onnx import numpy_helper

    weights = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    scale, total = 1.0, 0.0
    for node in model.graph.node:
        if node.op_type in ("MaxPool", "AveragePool"):
            scale /= 4
        elif node.op_type == "Resize":
            scale *= 4
        elif node.op_type == "Conv":
            total += weights[node.input[1]].size * scale
    return total
