"""U-Net-shaped ONNX models with random weights, built with onnx.helper (no torch): the test
and benchmark inputs of the GLSL executor (lift_gl/denoise/glsl_net.py).

    model = random_unet(encoder=(16, 32, 48, 64), bottleneck=80)   # an onnx.ModelProto
    onnx.save(model, "unet.onnx")

The shape follows OIDN's and the shipped denoiser's: per level a 3x3 conv + activation, a
2x2 pooling, a bottleneck, then per level an x2 upsampling, a skip (Concat, or Add where
`add_skips`), a 3x3 conv + activation, and a last conv to `out_channels`. `arch="rt"` is the
real-time model's shape (lift_gl/denoise/train/model.py RealTimeUNet): a 2x2 stride-2 conv
in, the levels from 1/2 down, and a 2x2 stride-2 ConvTranspose out. `colour_curve` wraps the
network in the trained models' input and output transform (the log curve on the colour
channels, and on the previous colour of a 13-channel temporal input; eps * exp(y) out), so
that a benchmark runs the graph a trained model exports. Weights are He-initialised
(std sqrt(2 / fan_in)) so activations stay near 1 through the depth.

    random_unet(encoder=(24, 32, 48), bottleneck=48, arch="rt", colour_curve=True)  # the rt model's graph
"""
from __future__ import annotations

import numpy as np

# lift_gl/denoise/train/model.py's (that module needs torch; tests/test_rt_model.py holds them equal)
LOG_EPS, LOG_CLAMP = 0.01, 25.0
CHROMA_EPS, CHROMA_RANGE = 1e-4, 3.0


def random_unet(in_channels: int = 9, out_channels: int = 3, encoder=(16, 32, 48, 64), bottleneck: int = 80,
                pool: str = "MaxPool", upsample=("nearest", "asymmetric"), activation: str = "Relu",
                add_skips: bool = False, final_kernel: int = 3, seed: int = 0, opset: int = 17,
                arch: str = "unet", colour_curve: bool = False, chroma_block: int = 0,
                passthrough: bool = False):
    """An onnx.ModelProto; `upsample` is (mode, coordinate_transformation_mode), or a list of
    those, one per decoder level (deepest first); `arch` "unet" or "rt", `colour_curve` the
    trained models' colour transform (module docstring); `chroma_block` k the rt model's chroma
    correction: the output times the clipped ratio of the input's and the output's kxk block
    means over their channel means, upsampled bilinearly (model.py); `passthrough` a fourth output channel blends the input
    colour in: y (1 - sigmoid(z)) + relu(colour) sigmoid(z) (model.py)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(seed)
    nodes, inits = [], []
    counter = iter(range(10 ** 6))

    def name(prefix):
        return f"{prefix}_{next(counter)}"

    def constant(value):
        c = name("const")
        inits.append(numpy_helper.from_array(np.asarray(value, np.float32), c))
        return c

    def node(op, inputs, **attrs):
        y = name(op.lower())
        nodes.append(helper.make_node(op, inputs, [y], **attrs))
        return y

    def conv(x, cin, cout, k=3, act=True, stride=1, transpose=False):
        w = name("w")
        b = name("b")
        shape = (cin, cout, k, k) if transpose else (cout, cin, k, k)
        fan_in = cin * (1 if transpose else k * k)  # a transposed conv's output sees one input pixel
        inits.append(numpy_helper.from_array(
            (rng.standard_normal(shape) * np.sqrt(2.0 / fan_in)).astype(np.float32), w))
        inits.append(numpy_helper.from_array((rng.standard_normal(cout) * 0.1).astype(np.float32), b))
        if transpose:
            y = node("ConvTranspose", [x, w, b], kernel_shape=[k, k], strides=[stride, stride])
        else:
            p = k // 2 if stride == 1 else 0  # stride 2 here: a 2x2 kernel, no padding
            y = node("Conv", [x, w, b], kernel_shape=[k, k], pads=[p, p, p, p], strides=[stride, stride])
        if not act:
            return y
        z = name("act")
        if activation == "LeakyRelu":
            nodes.append(helper.make_node("LeakyRelu", [y], [z], alpha=0.1))
        else:
            nodes.append(helper.make_node(activation, [y], [z]))
        return z

    def curve(x):  # model.py's "log" colour transform: log(1 + relu(x) / eps) / log(1 + 1 / eps)
        y = node("Add", [node("Mul", [node("Relu", [x]), constant(1.0 / LOG_EPS)]), constant(1.0)])
        return node("Mul", [node("Log", [y]), constant(1.0 / np.log1p(1.0 / LOG_EPS))])

    def channels(first, end, source="input"):
        return node("Slice", [source, constant_int([first]), constant_int([end]), constant_int([1]),
                              constant_int([1])])

    def constant_int(value):
        c = name("index")
        inits.append(numpy_helper.from_array(np.asarray(value, np.int64), c))
        return c

    if arch not in ("unet", "rt"):
        raise ValueError(f"arch must be unet or rt, not {arch!r}")
    ups = [upsample] * len(encoder) if isinstance(upsample[0], str) else list(upsample)
    h, skips, prev = "input", [], in_channels
    # one slice of the colour for the curve and the passthrough, as torch exports it
    colour = channels(0, out_channels) if colour_curve or passthrough or chroma_block else None
    if colour_curve:  # colour (and a temporal input's previous colour) through the curve
        pieces = [curve(colour), channels(3, min(in_channels, 9))]
        if in_channels > 9:
            pieces += [curve(channels(9, 12)), channels(12, in_channels)]
        h = node("Concat", pieces, axis=1)
    if arch == "rt":  # full resolution -> 1/2, a learned space-to-depth
        h = conv(h, prev, encoder[0], k=2, stride=2)
        prev = encoder[0]
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
    if arch == "rt":  # 1/2 -> full resolution, a learned depth-to-space
        y = conv(h, prev, out_channels + passthrough, k=2, stride=2, act=False, transpose=True)
    else:
        y = conv(h, prev, out_channels + passthrough, k=final_kernel, act=False)
    if passthrough:  # the blend weight from the fourth channel, the colour from the first three
        y, share = channels(0, out_channels, y), node("Sigmoid", [channels(out_channels, out_channels + 1, y)])
    if colour_curve:  # model.py's output: eps * exp(min(y, LOG_CLAMP))
        y = node("Mul", [node("Exp", [node("Clip", [y, "", constant(LOG_CLAMP)])]), constant(LOG_EPS)])
    relu_colour = node("Relu", [colour]) if passthrough or chroma_block else None  # one node for both, as torch's
    if passthrough:
        kept = node("Mul", [relu_colour, share])
        y = node("Add", [node("Mul", [y, node("Sub", [constant(1.0), share])]), kept])
    if chroma_block:  # model.py's _keep_chroma, as torch exports it
        k = chroma_block
        pool = lambda x: node("AveragePool", [x], kernel_shape=[k, k], strides=[k, k])
        grey = lambda x: node("Conv", [x, constant(np.full((1, 3, 1, 1), 1 / 3))], kernel_shape=[1, 1])
        eps = lambda x: node("Add", [x, constant(CHROMA_EPS)])
        mean_in, mean_out = pool(relu_colour), pool(y)
        ratio = node("Div", [node("Mul", [eps(mean_in), eps(grey(mean_out))]),
                             node("Mul", [eps(grey(mean_in)), eps(mean_out)])])
        ratio = node("Clip", [ratio, constant(1 / CHROMA_RANGE), constant(CHROMA_RANGE)])
        up = node("Resize", [ratio, "", constant([1, 1, k, k])], mode="linear",
                  coordinate_transformation_mode="pytorch_half_pixel")
        y = node("Mul", [y, up])
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
    """Conv multiply-adds per input pixel, each conv weighted by its output's share of the
    pixels (assumes the graph order random_unet builds: each level after its pooling or
    stride-2 conv, each decoder level after its upsampling)."""
    from onnx import helper, numpy_helper

    weights = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    scale, total = 1.0, 0.0
    for node in model.graph.node:
        strides = next((helper.get_attribute_value(a) for a in node.attribute if a.name == "strides"), [1, 1])
        if node.op_type in ("MaxPool", "AveragePool"):
            scale /= 4
        elif node.op_type == "Resize":
            scale *= 4
        elif node.op_type == "Conv":
            scale /= strides[0] ** 2
            total += weights[node.input[1]].size * scale
        elif node.op_type == "ConvTranspose":  # each output pixel meets one tap: a 1/s^2 of the weights
            total += weights[node.input[1]].size * scale
            scale *= strides[0] ** 2
    return total
