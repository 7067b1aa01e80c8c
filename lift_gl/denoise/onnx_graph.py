"""An ONNX convolutional network read into a plan of GPU steps (lift_gl/denoise/glsl_net.py runs it).

The plan covers what a U-Net denoiser uses: Conv (group 1, a square stride s with the
padding that gives size / s, so stride 1 keeps the size), ConvTranspose (kernel = stride, no
padding: a learned depth-to-space), MaxPool / AveragePool (kernel = stride, no padding),
Resize / Upsample by an integer factor (nearest or linear), Concat and Slice on channels,
Add / Sub / Mul / Div of two tensors (one may be a single channel, broadcast) or of a tensor
and a scalar, and pointwise Relu,
LeakyRelu, Clip, Log, Exp, Sqrt, Sigmoid, Tanh, Cast (to float), Identity. Anything else is
one ModelError naming the op, node and file.

Fusions, each saving a dispatch and a round trip of a tensor through memory:
- pointwise ops right after a Conv (its only consumer) become the Conv's epilogue;
- Concat costs nothing when only convolutions read it: a Conv reads its input in parts;
- the input transform (channel slices of the input, some through pointwise ops, concatenated
  back in order: the colour curve of lift_gl/denoise/train/model.py) becomes one map, and a
  map read only by a Conv becomes that Conv's prologue, applied to each texel it loads;
- a region of pointwise steps of one layer each (the passthrough's blend after the output
  conv) becomes one `fused` step, its values in registers.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from math import lcm
from pathlib import Path

import numpy as np

from ..errors import LiftError


class ModelError(LiftError):
    """An ONNX model the GLSL executor cannot run (unsupported op or attribute, bad file)."""


@dataclass
class Value:
    """A tensor of the graph: `channels` at `scale` times the input's width and height.

    `parts` is set for a Concat that was not copied: the names of the values it joins."""

    name: str
    channels: int
    scale: Fraction
    parts: list[str] | None = None


@dataclass
class Step:
    """One compute dispatch: `kind` is conv, conv_transpose, map, binary, gather, pool, resize or
    fused (a region of pointwise steps, `params["body"]` its GLSL).

    GLSL statements act on `v` (a vec4 of channels 4 layer .. 4 layer + 3, `layer` in scope):
    the epilogue on each value stored, a conv's prologue on each input texel it loads."""

    kind: str
    inputs: list[str]
    output: str
    epilogue: list[str] = field(default_factory=list)
    params: dict = field(default_factory=dict)
    prologue: list[str] = field(default_factory=list)


# pointwise ops with no constant operand: their GLSL statement on `v`
UNARY = {
    "Relu": "v = max(v, 0.0);",
    "Log": "v = log(v);",
    "Exp": "v = exp(v);",
    "Sqrt": "v = sqrt(v);",
    "Sigmoid": "v = 1.0 / (1.0 + exp(-v));",
    "Tanh": "v = tanh(v);",
    "Identity": "",
}
BINARY = {"Add": "+", "Sub": "-", "Mul": "*", "Div": "/"}
MAX_FUSED_INPUTS = 4  # the images a fused step reads (shaders/denoise/fused.comp)


def _glsl_float(x: float) -> str:
    x = float(np.float32(x))
    if not np.isfinite(x):
        return "(1.0/0.0)" if x > 0 else "(-1.0/0.0)"
    return repr(x) if "e" in repr(x) or "." in repr(x) else repr(x) + ".0"


class Plan:
    """The steps and values of an ONNX model; `multiple`: input sizes must be multiples of it."""

    def __init__(self, path):
        self.path = Path(path)
        try:
            import onnx
            from onnx import numpy_helper
        except ImportError:
            raise ModelError("the GLSL denoiser reads ONNX files with the `onnx` package: "
                             "pip install 'lift-gl[denoise]'", self.path) from None
        if not self.path.is_file():
            raise ModelError("model file not found", self.path)
        try:
            model = onnx.load(str(self.path))
        except Exception as exc:  # protobuf raises its own types for a foreign or cut file
            raise ModelError(f"not a loadable ONNX model ({type(exc).__name__}: {exc})", self.path) from None
        self._numpy = numpy_helper.to_array
        self._attr = onnx.helper.get_attribute_value
        graph = model.graph
        self.constants: dict[str, np.ndarray] = {t.name: self._numpy(t) for t in graph.initializer}
        inputs = [i for i in graph.input if i.name not in self.constants]
        if len(inputs) != 1 or len(graph.output) != 1:
            raise ModelError(f"expected one input and one output, found {len(inputs)} and {len(graph.output)}",
                             self.path)
        dims = inputs[0].type.tensor_type.shape.dim
        if len(dims) != 4 or not dims[1].dim_value:
            raise ModelError(f"input {inputs[0].name!r} must be NCHW with a fixed channel count", self.path)
        self.input_name = inputs[0].name
        self.output_name = graph.output[0].name
        self.values: dict[str, Value] = {self.input_name: Value(self.input_name, dims[1].dim_value, Fraction(1))}
        self.steps: list[Step] = []
        self.consumers: dict[str, int] = {}
        for node in graph.node:
            for name in node.input:
                if name:
                    self.consumers[name] = self.consumers.get(name, 0) + 1
        self.consumers[self.output_name] = self.consumers.get(self.output_name, 0) + 1
        self._producer: dict[str, Step] = {}
        for node in graph.node:
            self._add(node)
        if self.output_name not in self.values:
            raise ModelError(f"output {self.output_name!r} is not computed from the input", self.path)
        self._fuse_pointwise_tails()
        out = self.values[self.output_name]
        if out.parts is not None or self.output_name == self.input_name:
            self._emit(Step("gather", [self.output_name], self.output_name + "#copy",
                            params={"start": 0, "step": 1}), out.channels, out.scale)
            self.output_name += "#copy"
        self.multiple = lcm(*(v.scale.denominator for v in self.values.values()))
        # a texture padded at least this much is read by every step at a whole size
        self.output_channels = self.values[self.output_name].channels
        self.input_channels = self.values[self.input_name].channels

    # ---- helpers ----
    def _error(self, node, message: str) -> ModelError:
        return ModelError(f"node {node.name or node.output[0]!r} ({node.op_type}): {message}", self.path)

    def _attrs(self, node) -> dict:
        return {a.name: self._attr(a) for a in node.attribute}

    def _const(self, node, name: str) -> np.ndarray | None:
        return self.constants.get(name) if name else None

    def _tensor(self, node, name: str) -> Value:
        if name not in self.values:
            raise self._error(node, f"input {name!r} is neither the network's input nor computed from it "
                                    "(constant tensors are supported only as weights and scalars)")
        return self.values[name]

    def _emit(self, step: Step, channels: int, scale: Fraction) -> None:
        self.steps.append(step)
        self.values[step.output] = Value(step.output, channels, scale)
        self._producer[step.output] = step

    def _solid(self, node, name: str) -> str:
        """The name of a value stored in one texture: a Concat read by something other than a
        convolution is copied into one here."""
        value = self._tensor(node, name)
        if value.parts is None:
            return name
        copy = name + "#joined"
        if copy not in self.values:
            self._emit(Step("gather", [name], copy, params={"start": 0, "step": 1}), value.channels, value.scale)
        return copy

    def _pointwise(self, node, source: str, statement: str) -> None:
        """A pointwise op: fused into the step that made `source` when nothing else reads it."""
        out = node.output[0]
        producer = self._producer.get(source)
        if (producer is not None and producer.kind in ("conv", "conv_transpose", "map", "binary")
                and self.consumers.get(source, 0) == 1 and source != self.output_name):
            producer.epilogue.append(statement)
            producer.output = out
            value = self.values.pop(source)
            self.values[out] = Value(out, value.channels, value.scale)
            self._producer[out] = producer
            return
        source = self._solid(node, source)
        value = self.values[source]
        self._emit(Step("map", [source], out, epilogue=[statement]), value.channels, value.scale)

    # ---- pointwise regions: one dispatch ----
    def _fusable(self, step: Step) -> bool:
        """A step the fused shader can compute per pixel from values of at most one layer:
        a map, a binary, or a slice of channels within one layer of a stored tensor."""
        value = self.values[step.output]
        if value.channels > 4 or step.kind not in ("map", "binary", "gather"):
            return False
        if step.kind == "gather":
            start, source = step.params["start"], self.values[step.inputs[0]]
            return step.params["step"] == 1 and source.parts is None and start % 4 + value.channels <= 4
        return all(self.values[name].channels <= 4 and self.values[name].parts is None for name in step.inputs)

    def _fuse_pointwise_tails(self) -> None:
        """Each region of pointwise steps (maps, binaries, one-layer slices: `_fusable`) at one
        scale whose values nothing outside reads becomes one `fused` step: its values live in
        registers, not in textures (the passthrough's blend: 10 dispatches, then 1)."""
        readers: dict[str, list[Step]] = {}
        for step in self.steps:
            for name in step.inputs:
                readers.setdefault(name, []).append(step)
        for root in reversed(list(self.steps)):
            if root not in self.steps or not self._fusable(root):
                continue
            scale, region, frontier = self.values[root.output].scale, [root], list(root.inputs)
            while frontier:
                name = frontier.pop()
                step = self._producer.get(name)
                if (step is None or step in region or step not in self.steps or not self._fusable(step)
                        or self.values[name].scale != scale or name == self.output_name
                        or any(r not in region for r in readers.get(name, []))):
                    continue
                region.append(step)
                frontier += step.inputs
            region.sort(key=self.steps.index)
            made = {step.output for step in region}
            # the tensors the region reads from outside, in the order it first reads them
            sources = list(dict.fromkeys(name for step in region for name in step.inputs if name not in made))
            if len(region) < 2 or len(sources) > MAX_FUSED_INPUTS:
                continue
            self._emit_fused(region, sources, readers)

    def _emit_fused(self, region: list[Step], sources: list[str], readers: dict) -> None:
        """One `fused` step computing `region` (in order) per pixel from `sources` (image i:
        src i): external tensors loaded once a layer, each value a vec4 masked to its channels
        as a stored one would be."""
        inside = {step.output: f"t{i}" for i, step in enumerate(region)}
        loads: dict[tuple[str, int], str] = {}
        body: list[str] = []

        def texel(name: str, layer: int = 0) -> str:
            if name in inside:
                return inside[name]
            if (name, layer) not in loads:
                loads[(name, layer)] = f"x{len(loads)}"
                body.append(f"vec4 x{len(loads) - 1} = imageLoad(src{sources.index(name)}, ivec3(at.xy, {layer}));")
            return loads[(name, layer)]

        for step in region:
            channels = self.values[step.output].channels
            if step.kind == "gather":
                start = step.params["start"]
                source = texel(step.inputs[0], start // 4)
                lanes = ", ".join([f"{source}[{start % 4 + k}]" for k in range(channels)] + ["0.0"] * (4 - channels))
                value = f"vec4({lanes})"
            elif step.kind == "map":
                value = texel(step.inputs[0])
            else:
                a, b = (texel(name) for name in step.inputs)
                broadcast = step.params.get("broadcast")
                a, b = (a + ".xxxx" if broadcast == "a" else a), (b + ".xxxx" if broadcast == "b" else b)
                value = f"{a} {step.params['operator']} {b}"
            # each step's statements in a block of their own: two maps may declare the same names
            body.append(f"v = {value}; {{ {' '.join(step.epilogue)} }} vec4 {inside[step.output]} = mask_to(v, 0, {channels});")
        last = region[-1]
        body.append(f"v = {inside[last.output]};")
        fused = Step("fused", sources, last.output, params={"body": " ".join(body)})
        self.steps[self.steps.index(last)] = fused  # where the region ended: its readers come after
        self._producer[last.output] = fused
        for step in region[:-1]:
            self.steps.remove(step)
            del self._producer[step.output], self.values[step.output]
        for name in sources:
            readers.setdefault(name, []).append(fused)

    # ---- one node ----
    def _add(self, node) -> None:
        op, attrs = node.op_type, self._attrs(node)
        if op == "Constant":
            if "value" not in attrs:
                raise self._error(node, "only a tensor `value` is supported")
            self.constants[node.output[0]] = self._numpy(attrs["value"])
            return
        if op == "Identity" and node.input[0] in self.constants:  # the exporter's alias of a repeated weight
            self.constants[node.output[0]] = self.constants[node.input[0]]
            return
        if op in UNARY or op in ("LeakyRelu", "Clip", "Cast"):
            if op == "LeakyRelu":
                alpha = _glsl_float(attrs.get("alpha", 0.01))
                statement = f"v = max(v, 0.0) + {alpha} * min(v, 0.0);"
            elif op == "Clip":
                lo = self._const(node, node.input[1] if len(node.input) > 1 else "")
                hi = self._const(node, node.input[2] if len(node.input) > 2 else "")
                lo = attrs.get("min") if lo is None else float(lo)
                hi = attrs.get("max") if hi is None else float(hi)
                statement = ((f"v = max(v, {_glsl_float(lo)});" if lo is not None else "")
                             + (f"v = min(v, {_glsl_float(hi)});" if hi is not None else ""))
            elif op == "Cast":
                if attrs.get("to") != 1:
                    raise self._error(node, "only a cast to float32 is supported")
                statement = ""
            else:
                statement = UNARY[op]
            self._pointwise(node, node.input[0], statement)
            return
        if op in BINARY:
            self._binary(node, op)
        elif op == "Conv":
            self._conv(node, attrs)
        elif op == "ConvTranspose":
            self._conv_transpose(node, attrs)
        elif op in ("MaxPool", "AveragePool"):
            self._pool(node, op, attrs)
        elif op in ("Resize", "Upsample"):
            self._resize(node, op, attrs)
        elif op == "Concat":
            self._concat(node, attrs)
        elif op == "Slice":
            self._slice(node)
        else:
            raise ModelError(f"node {node.name or node.output[0]!r}: op {op} is not supported by the GLSL "
                             "executor (it runs Conv, ConvTranspose, MaxPool, AveragePool, Resize, Upsample, Concat, Slice, "
                             "Add, Sub, Mul, Div, Relu, LeakyRelu, Clip, Log, Exp, Sqrt, Sigmoid, Tanh, "
                             "Cast, Identity)", self.path)

    def _binary(self, node, op: str) -> None:
        a, b = node.input[:2]
        ca, cb = self._const(node, a), self._const(node, b)
        if ca is None and cb is None:
            va, vb = self._tensor(node, a), self._tensor(node, b)
            # one channel against many is broadcast over them (a blend weight times a colour)
            broadcast = "a" if va.channels == 1 < vb.channels else "b" if vb.channels == 1 < va.channels else ""
            if va.scale != vb.scale or (va.channels != vb.channels and not broadcast):
                raise self._error(node, "both tensors must have the same shape, or one a single channel "
                                        f"(not {va.channels} and {vb.channels} channels at scales {va.scale}, {vb.scale})")
            inputs = [self._solid(node, a), self._solid(node, b)]
            self._emit(Step("binary", inputs, node.output[0], params={"operator": BINARY[op], "broadcast": broadcast}),
                       max(va.channels, vb.channels), va.scale)
            return
        constant = ca if ca is not None else cb
        if constant.size != 1:
            raise self._error(node, f"a constant operand must be a scalar, not of shape {constant.shape}")
        c = _glsl_float(constant.reshape(()))
        statement = f"v = v {BINARY[op]} {c};" if cb is not None else f"v = {c} {BINARY[op]} v;"
        self._pointwise(node, a if cb is not None else b, statement)

    def _conv(self, node, attrs) -> None:
        weight = self._const(node, node.input[1])
        if weight is None or weight.ndim != 4:
            raise self._error(node, "the weights must be a 4-D constant tensor")
        bias = self._const(node, node.input[2]) if len(node.input) > 2 and node.input[2] else None
        out_ch, in_ch, kh, kw = weight.shape
        if attrs.get("group", 1) != 1:
            raise self._error(node, f"group = {attrs['group']} is not supported (only 1)")
        strides = list(attrs.get("strides", [1, 1]))
        if len(set(strides)) != 1 or any(d != 1 for d in attrs.get("dilations", [1, 1])):
            raise self._error(node, f"only equal strides and dilations 1 are supported, not strides {strides}")
        stride = int(strides[0])
        auto_pad = attrs.get("auto_pad", b"NOTSET")
        auto_pad = auto_pad.decode() if isinstance(auto_pad, bytes) else auto_pad
        if auto_pad in ("SAME_UPPER", "SAME_LOWER"):
            first = (kh - 1) // 2 if auto_pad == "SAME_UPPER" else kh // 2, (kw - 1) // 2 if auto_pad == "SAME_UPPER" else kw // 2
            pads = [first[0], first[1], kh - 1 - first[0], kw - 1 - first[1]]
        elif auto_pad in ("NOTSET", ""):
            pads = list(attrs.get("pads", [0, 0, 0, 0]))
        else:
            raise self._error(node, f"auto_pad {auto_pad} is not supported")
        # the output is size / stride for every size that is a multiple of the stride exactly when
        # k - s <= padding < k (floor((n + padding - k) / s) + 1 = n / s); stride 1: "same" padding
        if not all(k - stride <= p0 + p1 < k for k, p0, p1 in ((kh, pads[0], pads[2]), (kw, pads[1], pads[3]))):
            raise self._error(node, f"pads {pads} do not make the image size / {stride} for a {kh}x{kw} kernel "
                                    f"of stride {stride}")
        source = self._tensor(node, node.input[0])
        if source.channels != in_ch:
            raise self._error(node, f"weights expect {in_ch} input channels, the input has {source.channels}")
        parts, prologue = self._conv_source(node.input[0])
        bias = np.zeros(out_ch, np.float32) if bias is None else bias.astype(np.float32)
        self._emit(Step("conv", list(parts), node.output[0], prologue=prologue,
                        params={"weight": weight.astype(np.float32), "bias": bias, "pad": (pads[0], pads[1]),
                                "stride": stride, "part_channels": [self.values[p].channels for p in parts]}),
                   out_ch, source.scale / stride)

    def _conv_source(self, name: str) -> tuple[list[str], list[str]]:
        """The images a conv reads and the prologue on their texels: a map that only this conv
        reads is folded in (the conv applies its statements to the map's source as it loads)."""
        value = self.values[name]
        if value.parts is not None:
            return list(value.parts), []
        producer = self._producer.get(name)
        if (producer is not None and producer.kind == "map" and self.consumers.get(name, 0) == 1
                and name != self.output_name and self.values[producer.inputs[0]].parts is None):
            self.steps.remove(producer)
            del self.values[name], self._producer[name]
            return [producer.inputs[0]], list(producer.epilogue)
        return [name], []

    def _conv_transpose(self, node, attrs) -> None:
        weight = self._const(node, node.input[1])
        if weight is None or weight.ndim != 4:
            raise self._error(node, "the weights must be a 4-D constant tensor")
        in_ch, out_ch, kh, kw = weight.shape  # ONNX: (C_in, C_out / group, kH, kW)
        strides = list(attrs.get("strides", [1, 1]))
        if (attrs.get("group", 1) != 1 or [kh, kw] != strides or kh != kw or any(attrs.get("pads", [0] * 4))
                or any(attrs.get("output_padding", [0, 0])) or "output_shape" in attrs
                or any(d != 1 for d in attrs.get("dilations", [1, 1]))):
            raise self._error(node, f"only a square kernel equal to its stride, group 1, without padding is "
                                    f"supported (kernel {kh}x{kw}, strides {strides}, pads {attrs.get('pads')})")
        source = self._tensor(node, node.input[0])
        if source.channels != in_ch:
            raise self._error(node, f"weights expect {in_ch} input channels, the input has {source.channels}")
        parts = source.parts if source.parts is not None else [node.input[0]]
        bias = self._const(node, node.input[2]) if len(node.input) > 2 and node.input[2] else None
        bias = np.zeros(out_ch, np.float32) if bias is None else bias.astype(np.float32)
        # output pixel (y, x) is bias + W[:, :, y % s, x % s]^T . input(y / s, x / s): stored as a
        # conv's (O, I, kH, kW) weights, tap (ky, kx) chosen by the output pixel
        self._emit(Step("conv_transpose", list(parts), node.output[0],
                        params={"weight": np.ascontiguousarray(weight.transpose(1, 0, 2, 3)).astype(np.float32),
                                "bias": bias, "stride": kh, "part_channels": [self.values[p].channels for p in parts]}),
                   out_ch, source.scale * kh)

    def _pool(self, node, op: str, attrs) -> None:
        kernel = list(attrs.get("kernel_shape", []))
        strides = list(attrs.get("strides", kernel))
        if (len(kernel) != 2 or kernel != strides or kernel[0] != kernel[1] or any(attrs.get("pads", [0] * 4))
                or attrs.get("ceil_mode", 0) or any(d != 1 for d in attrs.get("dilations", [1, 1]))):
            raise self._error(node, f"only square kernels equal to their stride without padding are supported "
                                    f"(kernel {kernel}, strides {strides}, pads {attrs.get('pads')})")
        name = self._solid(node, node.input[0])
        value = self.values[name]
        self._emit(Step("pool", [name], node.output[0], params={"size": kernel[0], "max": op == "MaxPool"}),
                   value.channels, value.scale / kernel[0])

    def _resize(self, node, op: str, attrs) -> None:
        def text(key, default):
            v = attrs.get(key, default)
            return v.decode() if isinstance(v, bytes) else v

        mode = text("mode", "nearest")
        if op == "Upsample":
            scales = attrs.get("scales")
            if scales is None and len(node.input) > 1:
                scales = self._const(node, node.input[1])
            transform, nearest = "asymmetric", "floor"
        else:
            names = list(node.input) + [""] * 4
            scales = self._const(node, names[2]) if len(node.input) > 2 else self._const(node, names[1])
            if self._const(node, names[3]) is not None and self._const(node, names[3]).size:
                raise self._error(node, "a Resize by `sizes` is not supported (use `scales`)")
            transform = text("coordinate_transformation_mode", "half_pixel")
            nearest = text("nearest_mode", "round_prefer_floor")
        if scales is None or len(scales) != 4:
            raise self._error(node, "the scales must be a constant of 4 values")
        scales = [float(s) for s in scales]
        factor = scales[2]
        if scales[:2] != [1.0, 1.0] or scales[3] != factor or factor != int(factor) or factor < 1:
            raise self._error(node, f"only the same whole factor on H and W is supported, not scales {scales}")
        if mode not in ("nearest", "linear"):
            raise self._error(node, f"mode {mode} is not supported (nearest or linear)")
        if transform not in ("asymmetric", "half_pixel", "pytorch_half_pixel", "align_corners"):
            raise self._error(node, f"coordinate_transformation_mode {transform} is not supported")
        if mode == "nearest" and nearest not in ("floor", "ceil", "round_prefer_floor", "round_prefer_ceil"):
            raise self._error(node, f"nearest_mode {nearest} is not supported")
        name = self._solid(node, node.input[0])
        value = self.values[name]
        self._emit(Step("resize", [name], node.output[0],
                        params={"factor": int(factor), "linear": mode == "linear", "transform": transform,
                                "nearest": nearest}),
                   value.channels, value.scale * int(factor))

    def _concat(self, node, attrs) -> None:
        if attrs.get("axis") not in (1, -3):
            raise self._error(node, f"only a concatenation of channels (axis 1) is supported, not axis {attrs.get('axis')}")
        parts = []
        for name in node.input:
            value = self._tensor(node, name)
            parts += value.parts if value.parts is not None else [name]
        scales = {self.values[p].scale for p in parts}
        if len(scales) != 1:
            raise self._error(node, "the concatenated tensors have different sizes")
        if self._fuse_channel_map(node.output[0], parts):
            return
        self.values[node.output[0]] = Value(node.output[0], sum(self.values[p].channels for p in parts),
                                            scales.pop(), parts=parts)

    def _channel_range(self, name: str):
        """(source, first, end, statements) when `name` is a slice of channels first..end - 1
        (step 1) of a stored tensor, possibly through a map; `name` read only here, the slice
        under a map possibly elsewhere too (the passthrough reads the colour the curve maps)."""
        if self.consumers.get(name, 0) != 1 or name == self.output_name:
            return None
        step = self._producer.get(name)
        statements = []
        if step is not None and step.kind == "map":
            statements = step.epilogue
            step = self._producer.get(step.inputs[0])
        if step is None or step.kind != "gather" or step.params["step"] != 1 or step.epilogue:
            return None
        source = step.inputs[0]
        if self.values[source].parts is not None:
            return None
        first = step.params["start"]
        return source, first, first + self.values[step.output].channels, statements

    def _fuse_channel_map(self, out: str, parts: list[str]) -> bool:
        """A Concat of slices that tile one tensor's channels in order, some through pointwise
        ops: one map of that tensor, each range's statements applied to its channels."""
        ranges = [self._channel_range(p) for p in parts]
        if any(r is None for r in ranges) or len({r[0] for r in ranges}) != 1:
            return False
        source = ranges[0][0]
        if [r[1] for r in ranges] != [0] + [r[2] for r in ranges[:-1]] or ranges[-1][2] != self.values[source].channels:
            return False
        if not any(r[3] for r in ranges):
            return False  # a plain copy: the Concat's parts cost nothing as they are
        for name in parts:  # drop the slices and maps the one map replaces (a slice read elsewhere stays)
            while name in self._producer and name != source:
                if self.consumers.get(name, 0) > 1:
                    self.consumers[name] -= 1
                    break
                step = self._producer.pop(name)
                self.steps.remove(step)
                del self.values[name]
                name = step.inputs[0]
        statements = ["vec4 source_v = v; vec4 mapped_v = v;"]
        for _, first, end, chain in ranges:
            if chain:
                statements.append(f"v = source_v; {' '.join(chain)} "
                                  f"mapped_v = mix(mapped_v, v, channels_in(layer, {first}, {end}));")
        statements.append("v = mapped_v;")
        value = self.values[source]
        self._emit(Step("map", [source], out, epilogue=[" ".join(statements)]), value.channels, value.scale)
        return True

    def _slice(self, node) -> None:
        names = list(node.input) + [""] * 5
        starts, ends = self._const(node, names[1]), self._const(node, names[2])
        axes, steps = self._const(node, names[3]), self._const(node, names[4])
        if starts is None or ends is None or starts.size != 1:
            raise self._error(node, "only a slice of one axis with constant bounds is supported")
        axis = int(axes.reshape(-1)[0]) if axes is not None else 0
        step = int(steps.reshape(-1)[0]) if steps is not None else 1
        value = self._tensor(node, node.input[0])
        if axis not in (1, -3) or step < 1:
            raise self._error(node, f"only a forward slice of channels (axis 1) is supported, not axis {axis}, step {step}")
        start, end = (int(x.reshape(-1)[0]) for x in (starts, ends))
        start, stop, step = slice(start, end, step).indices(value.channels)
        channels = len(range(start, stop, step))
        if channels == 0:
            raise self._error(node, "the slice is empty")
        self._emit(Step("gather", [node.input[0]], node.output[0], params={"start": start, "step": step}),
                   channels, value.scale)
