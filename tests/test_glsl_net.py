"""The GLSL denoiser executor (lift_gl/denoise/glsl_net.py) against onnxruntime on random
U-Net-shaped ONNX models (lift_gl/denoise/random_unet.py), on odd image sizes.

Tolerance, from float32 rounding (u = 2^-24). A float32 K-term dot product rounds each of its
K partial sums s_k once, by s_k * delta_k with |delta_k| <= u; modelling the delta_k as
independent and uniform (Higham and Mary's probabilistic rounding analysis) gives an error
variance of (u^2 / 3) * sum_k s_k^2 <= (u^2 / 3) * K * (sum |w x| + |b|)^2. The next layers
carry that error through their weights: variance W^2 * var, summed with their own rounding.
A float64 numpy forward pass of the same graph propagates this variance alongside the values
(tests' own executor, a third independent implementation), and the two float32 executors may
differ by 6 * sqrt(2) * sigma elementwise (6 standard deviations of a difference of two
independent errors: about 1e-9 per element to fail by chance). An indexing bug (a wrong tap,
channel or weight) changes values by O(1), orders of magnitude above that.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from lift_gl.denoise.glsl_net import GlslNet, pack_weights  # noqa: E402
from lift_gl.denoise.onnx_graph import ModelError, Plan  # noqa: E402
from lift_gl.denoise.random_unet import random_unet  # noqa: E402

U = 2.0 ** -24


@pytest.fixture(scope="module")
def gl_ctx():
    from lift_gl.gl.context import create_context

    return create_context()


def onnxruntime_run(model, x):
    session = ort.InferenceSession(model.SerializeToString(), providers=["CPUExecutionProvider"])
    return session.run(None, {"input": x})[0]


def forward_float64(model, x):
    """The graph in float64 numpy, with the float32 rounding variance of every value."""
    from onnx import helper, numpy_helper

    consts = {t.name: numpy_helper.to_array(t).astype(np.float64) for t in model.graph.initializer}
    env = {model.graph.input[0].name: (x[0].astype(np.float64), np.zeros(x[0].shape))}  # (C, H, W) value, variance
    for node in model.graph.node:
        _forward_node(node, env, consts, helper, numpy_helper)
    v, var = env[model.graph.output[0].name]
    return v[None], var[None]


def _forward_node(node, env, consts, helper, numpy_helper):
    """One node of forward_float64: its value and float32 rounding variance into env."""
    attrs = {a.name: helper.get_attribute_value(a) for a in node.attribute}
    op, ins = node.op_type, node.input
    if op == "Constant":
        consts[node.output[0]] = numpy_helper.to_array(attrs["value"]).astype(np.float64)
    elif op in ("Add", "Sub", "Mul", "Div") and (ins[0] in consts or ins[1] in consts):
        (v, var), c = (env[ins[0]], consts[ins[1]]) if ins[1] in consts else (env[ins[1]], consts[ins[0]])
        c = float(c.reshape(()))
        y = {"Add": v + c, "Sub": v - c if ins[1] in consts else c - v, "Mul": v * c,
             "Div": v / c if ins[1] in consts else c / v}[op]
        slope = {"Add": 1.0, "Sub": 1.0, "Mul": c, "Div": 1 / c if ins[1] in consts else c / v ** 2}[op]
        env[node.output[0]] = (y, slope ** 2 * var + U ** 2 / 3 * y ** 2)
    elif op == "Log":  # GLSL: absolute error < 2^-21 in [0.5, 2], else 3 ULP (<= 6 u |y|)
        v, var = env[ins[0]]
        y = np.log(v)
        own = np.where((v >= 0.5) & (v <= 2.0), 2.0 ** -21, 6 * U * np.abs(y))
        env[node.output[0]] = (y, var / v ** 2 + own ** 2)
    elif op == "Exp":  # GLSL: (3 + 2 |x|) ULP
        v, var = env[ins[0]]
        y = np.exp(v)
        env[node.output[0]] = (y, y ** 2 * var + ((3 + 2 * np.abs(v)) * 2 * U * y) ** 2)
    elif op == "Clip":
        v, var = env[ins[0]]
        lo = consts[ins[1]] if len(ins) > 1 and ins[1] else -np.inf
        hi = consts[ins[2]] if len(ins) > 2 and ins[2] else np.inf
        env[node.output[0]] = (np.clip(v, lo, hi), var)
    elif op == "Cast":
        env[node.output[0]] = env[ins[0]]
    elif op == "Slice":
        v, var = env[ins[0]]
        start, end = int(consts[ins[1]].reshape(-1)[0]), int(consts[ins[2]].reshape(-1)[0])
        assert int(consts[ins[3]].reshape(-1)[0]) == 1, "the test's reference slices channels only"
        step = int(consts[ins[4]].reshape(-1)[0]) if len(ins) > 4 and ins[4] else 1
        env[node.output[0]] = (v[start:end:step], var[start:end:step])
    elif op == "Conv":
        (v, var), w = env[ins[0]], consts[ins[1]]
        b = consts[ins[2]] if len(ins) > 2 and ins[2] else np.zeros(w.shape[0])
        k, s = w.shape[2], attrs.get("strides", [1, 1])[0]
        top, left, bottom, right = attrs.get("pads", [k // 2] * 4)
        c, h, wd = v.shape
        h, wd = h // s, wd // s  # the output's size
        vp = np.pad(v, ((0, 0), (top, bottom + s), (left, right + s)))  # + s: room for the last strided tap
        varp = np.pad(var, ((0, 0), (top, bottom + s), (left, right + s)))
        out, carried = np.zeros((w.shape[0], h, wd)), np.zeros((w.shape[0], h, wd))
        size = np.broadcast_to(np.abs(b)[:, None, None], out.shape)  # sum |w x| + |b|
        for dy in range(k):
            for dx in range(k):
                taps = (slice(None), slice(dy, dy + s * h, s), slice(dx, dx + s * wd, s))
                tap = vp[taps]
                out += np.einsum("oc,chw->ohw", w[:, :, dy, dx], tap)
                carried += np.einsum("oc,chw->ohw", w[:, :, dy, dx] ** 2, varp[taps])
                size = size + np.einsum("oc,chw->ohw", np.abs(w[:, :, dy, dx]), np.abs(tap))
        terms = c * k * k + 1
        env[node.output[0]] = (out + b[:, None, None], carried + U ** 2 / 3 * terms * size ** 2)
    elif op == "ConvTranspose":  # kernel = stride: output (y, x) = b + W[:, :, y % s, x % s]^T v(y / s, x / s)
        (v, var), w = env[ins[0]], consts[ins[1]]
        b = consts[ins[2]]
        s = w.shape[2]
        c, h, wd = v.shape
        out, carried = np.zeros((w.shape[1], h * s, wd * s)), np.zeros((w.shape[1], h * s, wd * s))
        size = np.zeros(out.shape)
        for dy in range(s):
            for dx in range(s):
                at = (slice(None), slice(dy, None, s), slice(dx, None, s))
                out[at] = np.einsum("co,chw->ohw", w[:, :, dy, dx], v) + b[:, None, None]
                carried[at] = np.einsum("co,chw->ohw", w[:, :, dy, dx] ** 2, var)
                size[at] = np.einsum("co,chw->ohw", np.abs(w[:, :, dy, dx]), np.abs(v)) + np.abs(b)[:, None, None]
        env[node.output[0]] = (out, carried + U ** 2 / 3 * (c + 1) * size ** 2)
    elif op in ("Relu", "LeakyRelu", "Identity"):
        v, var = env[ins[0]]
        alpha = {"Relu": 0.0, "LeakyRelu": attrs.get("alpha", 0.01), "Identity": 1.0}[op]
        # slope 1 above 0, alpha below: where v is 6 sigma below 0 the error scales by alpha
        # (Relu: none is left), elsewhere by at most 1 (the op is 1-Lipschitz)
        env[node.output[0]] = (np.where(v >= 0, v, alpha * v), np.where(v < -6 * np.sqrt(var), alpha ** 2 * var, var))
    elif op in ("MaxPool", "AveragePool"):
        v, var = env[ins[0]]
        c, h, wd = v.shape
        k = int(attrs["kernel_shape"][0])
        blocks = v.reshape(c, h // k, k, wd // k, k)
        vb = var.reshape(c, h // k, k, wd // k, k)
        if op == "MaxPool":
            env[node.output[0]] = (blocks.max(axis=(2, 4)), vb.max(axis=(2, 4)))
        else:
            mean = blocks.mean(axis=(2, 4))
            env[node.output[0]] = (mean, vb.mean(axis=(2, 4)) + U ** 2 * k * k * mean ** 2)
    elif op == "Resize":
        v, var = env[ins[0]]
        mode, transform = attrs["mode"].decode(), attrs["coordinate_transformation_mode"].decode()
        c, h, wd = v.shape
        f = int(consts[ins[2]].reshape(-1)[2])  # the scales' factor on H (the same on W)

        def coords(n):
            out = np.arange(f * n, dtype=np.float64)
            if transform == "align_corners":
                x = out * (n - 1) / (f * n - 1)
            elif transform in ("half_pixel", "pytorch_half_pixel"):  # the same for sizes above 1
                x = (out + 0.5) / f - 0.5
            else:
                x = out / f
            if mode == "nearest":
                return np.clip(np.floor(x), 0, n - 1).astype(int), None, None
            x = np.clip(x, 0, n - 1)
            lo = np.floor(x).astype(int)
            return lo, np.minimum(lo + 1, n - 1), x - lo

        (y0, y1, ty), (x0, x1, tx) = coords(h), coords(wd)
        if mode == "nearest":
            env[node.output[0]] = (v[:, y0][:, :, x0], var[:, y0][:, :, x0])
        else:
            ty, tx = ty[None, :, None], tx[None, None, :]
            weights = [((1 - ty) * (1 - tx), y0, x0), ((1 - ty) * tx, y0, x1), (ty * (1 - tx), y1, x0), (ty * tx, y1, x1)]
            out = sum(wt * v[:, yy][:, :, xx] for wt, yy, xx in weights)
            carried = sum(wt ** 2 * var[:, yy][:, :, xx] for wt, yy, xx in weights)
            env[node.output[0]] = (out, carried + U ** 2 * 4 * out ** 2)
    elif op == "Concat":
        env[node.output[0]] = tuple(np.concatenate([env[i][j] for i in ins]) for j in (0, 1))
    elif op in ("Add", "Sub"):  # numpy broadcasts a one-channel operand as the executor does
        (a, va), (b, vb) = env[ins[0]], env[ins[1]]
        y = a + b if op == "Add" else a - b
        env[node.output[0]] = (y, va + vb + U ** 2 / 3 * y ** 2)
    elif op == "Mul":
        (a, va), (b, vb) = env[ins[0]], env[ins[1]]
        env[node.output[0]] = (a * b, b ** 2 * va + a ** 2 * vb + U ** 2 / 3 * (a * b) ** 2)
    elif op == "Div":  # GLSL's division: 2.5 ULP
        (a, va), (b, vb) = env[ins[0]], env[ins[1]]
        y = a / b
        env[node.output[0]] = (y, va / b ** 2 + y ** 2 * vb / b ** 2 + (2.5 * 2 * U * y) ** 2)
    elif op == "Sigmoid":  # 1 / (1 + exp(-v)) in GLSL: exp's (3 + 2 |v|) ULP, an add and a divide
        v, var = env[ins[0]]
        y = 1.0 / (1.0 + np.exp(-v))
        slope = y * (1.0 - y)
        env[node.output[0]] = (y, slope ** 2 * var + ((5 + 2 * np.abs(v)) * 2 * U * y) ** 2)
    else:
        raise AssertionError(f"the test's reference has no {op}")


def pad_edge(x, multiple):
    h, w = x.shape[2:]
    return np.pad(x, ((0, 0), (0, 0), (0, -h % multiple), (0, -w % multiple)), mode="edge")


def compare(gl_ctx, tmp_path, model, size, out_block, pixels):
    """GLSL, onnxruntime and the float64 reference pairwise within the derived bound."""
    path = tmp_path / "net.onnx"
    onnx.save(model, path)
    rng = np.random.default_rng(1)
    w, h = size
    channels = model.graph.input[0].type.tensor_type.shape.dim[1].dim_value
    x = rng.standard_normal((1, channels, h, w)).astype(np.float32)
    net = GlslNet(gl_ctx, path, out_block=out_block, pixels=pixels)
    try:
        got = net.run_numpy(x)
        with pytest.raises(ValueError, match="multiple"):  # the GPU path takes padded sizes only
            net.allocate(w, h)
    finally:
        net.release()
    # the same edge padding to the network's multiple as run_numpy, then the same crop
    padded = pad_edge(x, net.multiple)
    want = onnxruntime_run(model, padded)[:, :, :h, :w]
    exact, variance = forward_float64(model, padded)
    bound = 6 * np.sqrt(2 * variance[:, :, :h, :w])
    assert got.shape == want.shape == (1, 3, h, w)
    assert np.isfinite(got).all()
    for label, result in (("onnxruntime vs float64", want), ("GLSL vs float64", got), ("GLSL vs onnxruntime", got)):
        reference = exact[:, :, :h, :w] if "float64" in label else want
        diff = np.abs(result - reference)
        worst = np.unravel_index(np.argmax(diff / bound), diff.shape)
        assert (diff <= bound).all(), f"{label}: diff {diff[worst]:.3g} > bound {bound[worst]:.3g} at {worst}"
    # the comparison means something: the bound is far below the output and its variation
    assert bound.max() < 1e-3 * np.abs(want).max() and want.std() > 5 * bound.max()


def test_unet_concat_maxpool_nearest_matches_onnxruntime(gl_ctx, tmp_path):
    model = random_unet(encoder=(8, 12, 16), bottleneck=20, seed=3)
    compare(gl_ctx, tmp_path, model, (37, 29), out_block=1, pixels=8)  # the defaults


def test_unet_add_avgpool_bilinear_leaky_matches_onnxruntime(gl_ctx, tmp_path):
    # one decoder level per coordinate transform; 1x1 convs before the Add skips; a 1x1 output conv
    ups = [("linear", "half_pixel"), ("linear", "align_corners"), ("nearest", "asymmetric")]
    model = random_unet(encoder=(4, 8, 12), bottleneck=16, pool="AveragePool", upsample=ups,
                        activation="LeakyRelu", add_skips=True, final_kernel=1, seed=5)
    compare(gl_ctx, tmp_path, model, (29, 19), out_block=3, pixels=3)  # 3 does not divide 12 or 29


def test_unet_passthrough_matches_onnxruntime(gl_ctx, tmp_path):
    """model.py's passthrough: a fourth output channel's sigmoid blends the input colour in (a
    one-channel weight times a colour: the executor's broadcast)."""
    model = random_unet(encoder=(8, 12, 16), bottleneck=20, colour_curve=True, passthrough=True, seed=11)
    onnx.save(model, tmp_path / "pass.onnx")
    steps = Plan(tmp_path / "pass.onnx").steps
    # the colour the passthrough reads is the slice the curve maps: the curve stays fused; the
    # blend (slices, sigmoid, exp, products, sum) is one dispatch after the output conv
    assert steps[0].kind == "conv" and steps[0].prologue
    assert [s.kind for s in steps[-2:]] == ["conv", "fused"] and "fused" not in [s.kind for s in steps[:-1]]
    compare(gl_ctx, tmp_path, model, (37, 29), out_block=2, pixels=4)


def _hand_model(tmp_path, name, nodes, inits, out_channels):
    """A graph of `nodes` from a 9-channel input to `out_channels`, saved as NAME.onnx."""
    from onnx import TensorProto, helper

    graph = helper.make_graph(nodes, name, [helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, 9, "h", "w"])],
                              [helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, out_channels, "h", "w"])],
                              inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = min(model.ir_version, 8)
    onnx.save(model, tmp_path / f"{name}.onnx")
    return model, tmp_path / f"{name}.onnx"


def _assert_glsl_matches_onnxruntime(gl_ctx, model, path, x):
    net = GlslNet(gl_ctx, path)
    try:
        got = net.run_numpy(x)
    finally:
        net.release()
    want = onnxruntime_run(model, x)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5 * float(np.abs(want).max()))


def test_a_pointwise_region_of_five_inputs_is_fused_in_part_and_matches_onnxruntime(gl_ctx, tmp_path):
    """A sum of five convs' outputs would need five images in one fused step (it reads four):
    the first three sums are fused, the last stays a binary step."""
    from onnx import helper, numpy_helper

    rng = np.random.default_rng(5)
    inits, nodes = [], []
    for i in range(5):
        inits.append(numpy_helper.from_array(rng.standard_normal((3, 9, 1, 1)).astype(np.float32), f"w{i}"))
        nodes.append(helper.make_node("Conv", ["input", f"w{i}"], [f"c{i}"], kernel_shape=[1, 1]))
    total = "c0"
    for i in range(1, 5):
        nodes.append(helper.make_node("Add", [total, f"c{i}"], [f"s{i}" if i < 4 else "output"]))
        total = f"s{i}"
    model, path = _hand_model(tmp_path, "sum5", nodes, inits, 3)
    steps = Plan(path).steps
    assert [s.kind for s in steps] == ["conv"] * 5 + ["fused", "binary"] and len(steps[5].inputs) == 4
    _assert_glsl_matches_onnxruntime(gl_ctx, model, path, rng.standard_normal((1, 9, 7, 9)).astype(np.float32))


def test_a_broadcast_product_of_many_channels_matches_onnxruntime(gl_ctx, tmp_path):
    """A one-channel weight times 8 channels: too wide to fuse (a fused value holds one layer),
    so the binary step broadcasts; the sigmoid of the slice before it is a fused region."""
    from onnx import helper, numpy_helper

    rng = np.random.default_rng(4)
    w = numpy_helper.from_array(rng.standard_normal((8, 9, 3, 3)).astype(np.float32) * 0.3, "w")
    index = [numpy_helper.from_array(np.array([v], np.int64), n) for v, n in ((0, "start"), (1, "end"), (1, "axis"))]
    nodes = [helper.make_node("Conv", ["input", "w"], ["y"], kernel_shape=[3, 3], pads=[1, 1, 1, 1]),
             helper.make_node("Slice", ["input", "start", "end", "axis"], ["first"]),
             helper.make_node("Sigmoid", ["first"], ["share"]),
             helper.make_node("Mul", ["y", "share"], ["output"])]
    model, path = _hand_model(tmp_path, "broadcast", nodes, [w] + index, 8)
    steps = Plan(path).steps
    assert [s.kind for s in steps] == ["conv", "fused", "binary"] and steps[-1].params["broadcast"] == "b"
    _assert_glsl_matches_onnxruntime(gl_ctx, model, path, rng.standard_normal((1, 9, 13, 11)).astype(np.float32))


def test_rt_passthrough_matches_onnxruntime(gl_ctx, tmp_path):
    """The rt model's passthrough: the transposed conv's fourth channel is the blend's share."""
    model = random_unet(in_channels=13, encoder=(8, 12, 16), bottleneck=20, arch="rt", colour_curve=True,
                        passthrough=True, seed=12)
    onnx.save(model, tmp_path / "pass.onnx")
    steps = Plan(tmp_path / "pass.onnx").steps
    assert steps[0].kind == "conv" and steps[0].prologue  # the curve fused into the strided conv
    assert [s.kind for s in steps[-2:]] == ["conv_transpose", "fused"]
    compare(gl_ctx, tmp_path, model, (40, 32), out_block=2, pixels=4)


def test_rt_strided_conv_and_transposed_conv_match_onnxruntime(gl_ctx, tmp_path):
    """The rt shape: a 2x2 stride-2 conv in, a 2x2 stride-2 ConvTranspose out."""
    model = random_unet(encoder=(8, 12, 16), bottleneck=20, arch="rt", seed=7)
    compare(gl_ctx, tmp_path, model, (37, 29), out_block=2, pixels=3)  # 3 pixels: a strided row of odd length


def test_rt_chroma_correction_matches_onnxruntime_and_keeps_the_curve_fused(gl_ctx, tmp_path):
    """The rt model's chroma correction (block means of input and output, their ratio over the
    channel means, clipped, upsampled bilinearly, times the output) runs, and the first conv
    still reads the input through its own fused curve though the correction reads the colour too."""
    model = random_unet(in_channels=13, encoder=(8, 12, 16), bottleneck=20, arch="rt",
                        colour_curve=True, passthrough=True, chroma_block=8, seed=9)
    onnx.save(model, tmp_path / "chroma.onnx")
    steps = Plan(tmp_path / "chroma.onnx").steps
    assert steps[0].kind == "conv" and steps[0].prologue
    assert [s.kind for s in steps].count("resize") == 4  # three decoder levels and the ratio
    compare(gl_ctx, tmp_path, model, (40, 32), out_block=2, pixels=4)


@pytest.mark.parametrize("channels", [9, 13])
def test_colour_curve_fused_into_the_first_conv_matches_onnxruntime(gl_ctx, tmp_path, channels):
    """The trained models' colour curve (13 channels: the temporal input's previous colour
    too), fused as the first conv's prologue: no gather or map left."""
    model = random_unet(in_channels=channels, encoder=(8, 12, 16), bottleneck=20, arch="rt",
                        colour_curve=True, seed=8)
    onnx.save(model, tmp_path / "curve.onnx")
    steps = Plan(tmp_path / "curve.onnx").steps
    assert steps[0].kind == "conv" and steps[0].prologue and not any(s.kind in ("gather", "map") for s in steps)
    compare(gl_ctx, tmp_path, model, (37, 29), out_block=1, pixels=8)


def test_unsupported_conv_transpose_is_clear(tmp_path):
    from onnx import helper, numpy_helper

    w = numpy_helper.from_array(np.zeros((4, 4, 3, 3), np.float32), "w")
    path = _save(tmp_path, [helper.make_node("ConvTranspose", ["input", "w"], ["output"], kernel_shape=[3, 3],
                                             strides=[2, 2], name="up")], [w])
    with pytest.raises(ModelError, match=r"bad\.onnx.*up.*kernel equal to its stride"):
        Plan(path)


def test_weight_packing_order():
    # mat4 column c = input channel, row r = output channel (column-major in the buffer)
    weight = np.arange(6 * 5 * 3 * 3, dtype=np.float32).reshape(6, 5, 3, 3)
    packed, groups = pack_weights(weight, [2, 3], out_block=1)
    assert groups == 2 and packed.shape == (2, 2, 3, 3, 1, 4, 4)  # g, input layer, ky, kx, j, c, r
    assert packed[0, 0, 1, 2, 0, 1, 3] == weight[3, 1, 1, 2]      # part 0's channel 1
    assert packed[1, 1, 0, 0, 0, 2, 1] == weight[5, 4, 0, 0]      # part 1 (layer 1) channel 2 = input 4
    assert packed[1, 0, 0, 0, 0, 0, 2] == 0.0                     # output channel 6 does not exist


SHIPPED = Path(__file__).resolve().parent.parent / "assets" / "denoiser" / "lift_unet.onnx"


@pytest.mark.parametrize("shipped", [SHIPPED, SHIPPED.with_name("lift_rt.onnx")], ids=["unet", "rt"])
def test_shipped_denoiser_matches_onnxruntime(gl_ctx, shipped):
    """The trained models (Slice, Log, Exp, Clip around the U-Net; the passthrough's blend)
    within their rounding bound; rt's temporal input with a previous frame half valid."""
    if not shipped.is_file():
        pytest.skip(f"{shipped} is absent (trained by lift_gl/denoise/train)")
    model = onnx.load(str(shipped))
    channels = model.graph.input[0].type.tensor_type.shape.dim[1].dim_value
    rng = np.random.default_rng(2)
    h, w = 29, 37
    x = rng.random((1, channels, h, w)).astype(np.float32)
    x[:, :3] *= 4.0  # exposed colour, albedo in [0, 1], normals in [-1, 1]
    x[:, 6:9] = 2 * x[:, 6:9] - 1
    if channels == 13:  # the previous output (exposed colour) and its validity
        x[:, 9:12] *= 4.0
        x[:, 12] = x[:, 12] > 0.5
        x[:, 9:12] *= x[:, 12:13]
    net = GlslNet(gl_ctx, shipped)
    try:
        got = net.run_numpy(x)
    finally:
        net.release()
    padded = pad_edge(x, net.multiple)
    session = ort.InferenceSession(str(shipped), providers=["CPUExecutionProvider"])
    want = session.run(None, {session.get_inputs()[0].name: padded})[0][:, :, :h, :w]
    exact, variance = forward_float64(model, padded)
    bound = 6 * np.sqrt(2 * variance[:, :, :h, :w])
    diff = np.abs(got - want)
    worst = np.unravel_index(np.argmax(diff / bound), diff.shape)
    assert (diff <= bound).all(), f"diff {diff[worst]:.3g} > bound {bound[worst]:.3g} at {worst}"
    assert (np.abs(want - exact[:, :, :h, :w]) <= bound).all()


def _noisy_frame(rng, h, w):
    """A frame for the denoiser executors: colour = albedo times exponential noise, unit normals."""
    albedo = rng.random((h, w, 3)).astype(np.float32)
    color = (albedo * rng.exponential(1.0, (h, w, 1))).astype(np.float32)
    normal = rng.standard_normal((h, w, 3)).astype(np.float32)
    normal /= np.linalg.norm(normal, axis=2, keepdims=True)
    return color, albedo, normal


def test_glsl_denoiser_matches_onnx_denoiser(gl_ctx):
    """GlslDenoiser and OnnxDenoiser (lift_gl/denoise/onnx_denoiser.py) on one noisy frame: the
    network's bound carried through the output transform (divide by the exposure, times albedo)."""
    if not SHIPPED.is_file():
        pytest.skip(f"{SHIPPED} is absent (trained by lift_gl/denoise/train)")
    from lift_gl.denoise.glsl_denoiser import GlslDenoiser
    from lift_gl.denoise.onnx_denoiser import OnnxDenoiser

    h, w = 23, 41
    color, albedo, normal = _noisy_frame(np.random.default_rng(4), h, w)
    glsl = GlslDenoiser(ctx=gl_ctx)
    try:
        got = glsl.denoise(color, albedo, normal)
    finally:
        glsl.release()
    want = OnnxDenoiser(providers=["CPUExecutionProvider"]).denoise(color, albedo, normal)
    bound = denoiser_bound(color, albedo, normal, want)
    assert got.shape == want.shape == (h, w, 3)
    assert (np.abs(got - want) <= bound).all(), np.abs(got - want).max()


def test_glsl_denoiser_ensemble_matches_onnx_denoiser(gl_ctx):
    """With ensemble=2 (the image and its mirror image, averaged) both executors agree within
    the mean of the two passes' bounds."""
    if not SHIPPED.is_file():
        pytest.skip(f"{SHIPPED} is absent (trained by lift_gl/denoise/train)")
    from lift_gl.denoise.glsl_denoiser import GlslDenoiser
    from lift_gl.denoise.onnx_denoiser import OnnxDenoiser

    h, w = 19, 37
    color, albedo, normal = _noisy_frame(np.random.default_rng(5), h, w)
    glsl = GlslDenoiser(ctx=gl_ctx, ensemble=2)
    try:
        got = glsl.denoise(color, albedo, normal)
    finally:
        glsl.release()
    onnx_cpu = dict(providers=["CPUExecutionProvider"])
    want = OnnxDenoiser(ensemble=2, **onnx_cpu).denoise(color, albedo, normal)
    single = OnnxDenoiser(ensemble=1, **onnx_cpu)
    mirror = lambda a: np.ascontiguousarray(a[:, ::-1])
    bounds = [denoiser_bound(color, albedo, normal, single.denoise(color, albedo, normal)),
              mirror(denoiser_bound(*map(mirror, (color, albedo, normal)),
                                    single.denoise(*map(mirror, (color, albedo, normal)))))]
    bound = (bounds[0] + bounds[1]) / 2 + 4 * U * np.abs(want)  # plus the mean's own rounding
    assert np.abs(want - single.denoise(color, albedo, normal)).max() > 10 * bound.max()  # the ensemble differs
    assert (np.abs(got - want) <= bound).all(), np.abs(got - want).max()


def test_renderer_texture_path_refuses_an_ensemble(gl_ctx):
    from lift_gl.denoise.glsl_denoiser import GlslDenoiser
    from lift_gl.errors import DenoiserError
    from lift_gl.passes.denoise import DenoisePass

    with pytest.raises(DenoiserError, match="ensemble"):
        DenoisePass(gl_ctx, (16, 16), "glsl", numpy_denoiser=GlslDenoiser(ctx=gl_ctx, ensemble=2))


def denoiser_bound(color, albedo, normal, want):
    """How far GlslDenoiser may differ from OnnxDenoiser on these inputs: the network's
    rounding bound (above) carried through the output transform (divide by the exposure,
    times albedo), plus the output transform's own two roundings on each side."""
    from lift_gl.denoise.demodulate import safe_albedo
    from lift_gl.denoise.model_io import network_input

    h, w = color.shape[:2]
    x, exposure = network_input(color, albedo, normal)
    _, variance = forward_float64(onnx.load(str(SHIPPED)), pad_edge(x, 16))
    bound = 6 * np.sqrt(2 * variance[0, :, :h, :w]).transpose(1, 2, 0) / exposure * safe_albedo(np.clip(albedo, 0, 1))
    return bound + 4 * U * np.abs(want)


def test_cli_glsl_denoiser_matches_onnx(tmp_path, capsys):
    """`lift-gl render --denoise final --denoiser glsl` against `--denoiser onnx` on the repo's
    Cornell box: the same noisy mean (same seed), the same guides (the G-buffer is rendered
    unjittered), so the outputs differ only by the executors' rounding, within denoiser_bound
    computed on the noisy mean and the guides the CLI writes."""
    if not SHIPPED.is_file():
        pytest.skip(f"{SHIPPED} is absent (trained by lift_gl/denoise/train)")
    from lift_gl.cli import main

    scene = str(Path(__file__).resolve().parent.parent / "scenes" / "cornell.toml")
    common = [scene, "--size", "37x29", "--spp", "2", "--seed", "5"]
    for name in ("glsl", "onnx"):
        assert main(["render", *common, "--denoise", "final", "--denoiser", name,
                     "--out", str(tmp_path / f"{name}.npy"), "--noisy-out", str(tmp_path / f"noisy_{name}.npy")]) == 0
        assert f"denoised ({name}, final frame" in capsys.readouterr().out  # the executor asked for ran
    for aov in ("albedo", "normal"):
        assert main(["render", *common, "--aov", aov, "--out", str(tmp_path / f"{aov}.npy")]) == 0
    got, noisy = (np.load(tmp_path / f"{n}.npy")[..., :3] for n in ("glsl", "noisy_glsl"))
    np.testing.assert_array_equal(noisy, np.load(tmp_path / "noisy_onnx.npy")[..., :3])
    albedo, normal = (np.load(tmp_path / f"{n}.npy")[..., :3] for n in ("albedo", "normal"))
    # The renderer's GLSL road runs the network once; the CLI's onnx denoiser runs the sidecar's
    # self-ensemble (inference.ensemble), so onnxruntime's single pass is the comparison, on the
    # inputs the CLI wrote (the same noisy mean and unjittered guides).
    from lift_gl.denoise.onnx_denoiser import OnnxDenoiser
    want = OnnxDenoiser(providers=["CPUExecutionProvider"], ensemble=1).denoise(noisy, albedo, normal)
    ensemble = OnnxDenoiser(providers=["CPUExecutionProvider"]).denoise(noisy, albedo, normal)
    assert np.abs(np.load(tmp_path / "onnx.npy")[..., :3] - ensemble).max() <= 1e-5 * max(1.0, float(ensemble.max()))
    bound = denoiser_bound(noisy, albedo, normal, want)
    assert got.shape == want.shape == (29, 37, 3)
    # the denoiser did something the bound would see: its change is 2600x the bound's mean with
    # the step-2604 weights, 790x with the shipped ones; the executors differ by < 0.03 of it
    assert np.abs(want - noisy).mean() > 1e2 * bound.mean()
    assert (np.abs(got - want) <= bound).all(), (np.abs(got - want) / bound).max()


def _save(tmp_path, nodes, inits=(), name="bad.onnx"):
    from onnx import TensorProto, helper

    graph = helper.make_graph(nodes, "g", [helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, 4, "h", "w"])],
                              [helper.make_tensor_value_info("output", TensorProto.FLOAT, [1, 4, "h", "w"])],
                              list(inits))
    path = tmp_path / name
    onnx.save(helper.make_model(graph), path)
    return path


def test_unsupported_op_names_op_and_file(tmp_path):
    from onnx import helper

    path = _save(tmp_path, [helper.make_node("Softmax", ["input"], ["output"], axis=1, name="attention")])
    with pytest.raises(ModelError) as info:
        Plan(path)
    message = str(info.value)
    assert "Softmax" in message and "bad.onnx" in message and "attention" in message


def test_identity_of_a_weight_is_the_weight(gl_ctx, tmp_path):
    """torch's exporter writes a repeated weight (a layer grown as the identity) once and
    Identity nodes for the others: the executor reads them as the weight."""
    from onnx import helper, numpy_helper

    w = np.random.default_rng(2).standard_normal((4, 4, 3, 3)).astype(np.float32)
    b = np.zeros(4, np.float32)
    path = _save(tmp_path, [helper.make_node("Identity", ["w"], ["w2"]),
                            helper.make_node("Conv", ["input", "w2", "b"], ["output"], kernel_shape=[3, 3],
                                             pads=[1, 1, 1, 1])],
                 [numpy_helper.from_array(w, "w"), numpy_helper.from_array(b, "b")], name="alias.onnx")
    x = np.random.default_rng(3).standard_normal((1, 4, 8, 8)).astype(np.float32)
    net = GlslNet(gl_ctx, path)
    try:
        got = net.run_numpy(x)
    finally:
        net.release()
    want = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"]).run(None, {"input": x})[0]
    np.testing.assert_allclose(got, want, atol=1e-4)


def test_unsupported_conv_attribute_is_clear(tmp_path):
    from onnx import helper, numpy_helper

    w = numpy_helper.from_array(np.zeros((4, 4, 3, 3), np.float32), "w")
    path = _save(tmp_path, [helper.make_node("Conv", ["input", "w"], ["output"], kernel_shape=[3, 3],
                                             pads=[1, 1, 1, 1], strides=[2, 1])], [w])
    with pytest.raises(ModelError, match=r"bad\.onnx.*Conv.*equal strides"):
        Plan(path)
    path = _save(tmp_path, [helper.make_node("Conv", ["input", "w"], ["output"], kernel_shape=[3, 3],
                                             pads=[0, 0, 0, 0], strides=[2, 2])], [w], name="pads.onnx")
    with pytest.raises(ModelError, match=r"pads\.onnx.*size / 2"):  # 3x3 stride 2 wants 1 or 2 pixels of padding
        Plan(path)


def test_missing_and_corrupt_model_files(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        Plan(tmp_path / "absent.onnx")
    corrupt = tmp_path / "corrupt.onnx"
    corrupt.write_bytes(b"\x08\x07this is not a protobuf")
    with pytest.raises(ModelError, match="corrupt.onnx"):
        Plan(corrupt)
