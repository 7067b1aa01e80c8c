"""An ONNX convolutional network run in OpenGL 4.3 compute shaders, from the model's own weights:
the denoiser on any GPU (or llvmpipe) without CUDA or onnxruntime.

    net = GlslNet(ctx, "assets/denoiser/lift_unet.onnx")
    y = net.run_numpy(x)            # (1, C, H, W) float32 -> (1, C_out, H, W), any H and W
    net.allocate(width, height)     # or stay on the GPU: sizes multiples of net.multiple
    net.input_texture.write(...)    # image2DArray (rgba32f), channel c in layer c // 4
    net.run(); net.output_texture   # the same layout; row 0 is the top of the picture

The graph is read by lift_gl/denoise/onnx_graph.py into steps; here each step becomes one
compute dispatch (shaders/denoise/). Weights are uploaded once; intermediate textures are
allocated once per resolution and reused once their last reader has run. Tensors are
float32 (rgba32f); half storage (rgba16f) measured slower on an H200 (docs/denoiser.md).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import shaders
from ..bindings import STORAGE_BUFFERS
from .onnx_graph import ModelError, Plan, Step

SHADER_DIR = shaders.SHADER_DIR / "denoise"
LOCAL_SIZE = 8
MAX_PARTS = 4  # input images of one conv or gather (shaders/denoise/conv.comp)
# conv invocation's work: output layers (of 4 channels) and pixels of a row, measured with
# benchmarks/glsl_denoiser.py --variants (docs/glsl-denoiser.md): 1x8 was fastest on llvmpipe
# (each weight load serves 8 pixels), 2x4 on an H100 (15.6 ms at 1080p against 25.0 for 1x8).
DEFAULT_OUT_BLOCK = 1
DEFAULT_PIXELS = 8
GPU_OUT_BLOCK, GPU_PIXELS = 2, 4


def default_shape(ctx) -> tuple[int, int]:
    """The conv shape (output layers, pixels) for this context: CPU rasterizer or GPU."""
    from ..gl.context import is_software

    return (DEFAULT_OUT_BLOCK, DEFAULT_PIXELS) if is_software(ctx) else (GPU_OUT_BLOCK, GPU_PIXELS)


TENSOR_FORMAT = "rgba32f"  # the tensors' image format (shaders/denoise/tensor.glsl)


NEAREST_MODES = ("floor", "ceil", "round_prefer_floor", "round_prefer_ceil")


def layers(channels: int) -> int:
    return (channels + 3) // 4


def pack_weights(weight: np.ndarray, part_channels: list[int], out_block: int) -> tuple[np.ndarray, np.ndarray]:
    """Conv weights (O, I, KH, KW) as the mat4 stream conv.comp reads, and the bias padding.

    Order: group g of `out_block` output layers, then input layer (parts one after another,
    each padded to whole layers), ky, kx, output layer j of the group; each mat4 is stored
    column-major with column c = input channel 4l+c, row r = output channel 4(g*B+j)+r.
    """
    out_ch, in_ch, kh, kw = weight.shape
    groups = -(-layers(out_ch) // out_block)
    in_layers = sum(layers(c) for c in part_channels)
    padded = np.zeros((groups * out_block * 4, in_layers * 4, kh, kw), np.float32)
    src, dst = 0, 0
    for c in part_channels:  # each part starts on a whole layer
        padded[:out_ch, dst:dst + c] = weight[:, src:src + c]
        src, dst = src + c, dst + 4 * layers(c)
    blocks = padded.reshape(groups, out_block, 4, in_layers, 4, kh, kw)  # g j r l c ky kx
    return np.ascontiguousarray(blocks.transpose(0, 3, 5, 6, 1, 4, 2)), groups


class GlslNet:
    """The steps of an ONNX model as compute dispatches on a moderngl context."""

    def __init__(self, ctx, model_path, out_block: int | None = None, pixels: int | None = None):
        """out_block, pixels: the conv kernel's shape; None: default_shape(ctx)."""
        self.ctx = ctx
        self.model_path = Path(model_path)
        self.tensor_format = TENSOR_FORMAT
        # what a shader writing or reading these tensors is compiled with (shaders/denoise/tensor.glsl)
        self.tensor_defines = {"TENSOR_FORMAT": self.tensor_format}
        self.plan = Plan(self.model_path)
        default_block, default_pixels = default_shape(ctx)
        self.out_block = int(default_block if out_block is None else out_block)
        self.pixels = int(default_pixels if pixels is None else pixels)
        self.multiple = self.plan.multiple
        self.input_channels = self.plan.input_channels
        self.output_channels = self.plan.output_channels
        self._programs: dict[tuple, object] = {}
        self._weights: dict[int, tuple] = {}  # id(step) -> (weights buffer, bias buffer)
        for step in self.plan.steps:
            if len(self._inputs(step)) > MAX_PARTS:
                raise ModelError(f"{step.output!r} reads {len(self._inputs(step))} concatenated tensors; "
                                 f"at most {MAX_PARTS} are supported", self.model_path)
            self._program(step)  # compile everything now: errors at load, not at the first frame
            if step.kind in ("conv", "conv_transpose"):
                packed, groups = pack_weights(step.params["weight"], step.params["part_channels"], self.out_block)
                bias = np.zeros((groups * self.out_block * 4,), np.float32)
                bias[:len(step.params["bias"])] = step.params["bias"]
                self._weights[id(step)] = (ctx.buffer(packed.tobytes()), ctx.buffer(bias.tobytes()))
        self.size: tuple[int, int] | None = None
        self._textures: dict[str, object] = {}
        self._owned: list = []

    # ---- programs ----
    def _inputs(self, step: Step) -> list[str]:
        """The images a step reads: a Concat's parts one by one."""
        names = []
        for name in step.inputs:
            value = self.plan.values.get(name)
            names += value.parts if value is not None and value.parts is not None else [name]
        return names

    def _program(self, step: Step):
        defines = {"EPILOGUE": " ".join(step.epilogue) or "/* none */", **self.tensor_defines}
        if step.kind == "conv":
            kh, kw = step.params["weight"].shape[2:]
            parts = step.params["part_channels"]
            defines.update(KERNEL_H=kh, KERNEL_W=kw, PAD_TOP=step.params["pad"][0], PAD_LEFT=step.params["pad"][1],
                           STRIDE=step.params["stride"], OUT_BLOCK=self.out_block, PIXELS=self.pixels,
                           NUM_PARTS=len(parts))
            if step.prologue:
                defines.update(PROLOGUE=" ".join(step.prologue), PROLOGUE_CHANNELS=parts[0])
            source = "conv.comp"
        elif step.kind == "conv_transpose":
            defines.update(STRIDE=step.params["stride"], OUT_BLOCK=self.out_block,
                           NUM_PARTS=len(step.params["part_channels"]))
            source = "conv_transpose.comp"
        elif step.kind in ("map", "binary"):
            source = "pointwise.comp"
            if step.kind == "binary":
                defines["OPERATOR"] = step.params["operator"]
                if step.params.get("broadcast"):
                    defines["BROADCAST_" + step.params["broadcast"].upper()] = 1
        elif step.kind == "gather":
            source = "gather.comp"
            defines["NUM_PARTS"] = len(self._inputs(step))
        elif step.kind == "fused":
            source = "fused.comp"
            defines.update(BODY=step.params["body"], NUM_INPUTS=len(step.inputs))
        elif step.kind == "pool":
            source = "pool.comp"
            defines.update(POOL_SIZE=step.params["size"], POOL_MAX=step.params["max"])
        else:
            source = "resize.comp"
            defines["LINEAR"] = step.params["linear"]
        key = (source, tuple(sorted(defines.items())))
        if key not in self._programs:
            self._programs[key] = shaders.compile_compute(self.ctx, shaders.assemble(SHADER_DIR / source, defines))
        return self._programs[key]

    # ---- textures, once per resolution ----
    def allocate(self, width: int, height: int) -> None:
        """Textures for an input of width x height (multiples of self.multiple); a texture
        whose last reader has run is handed to a later step of the same shape."""
        if (width, height) == self.size:
            return
        if width % self.multiple or height % self.multiple or width <= 0 or height <= 0:
            raise ValueError(f"the GPU input must be a positive multiple of {self.multiple} a side, not "
                             f"{width}x{height} (run_numpy pads)")
        self._release_textures()
        values = self.plan.values
        last_read: dict[str, int] = {}
        for index, step in enumerate(self.plan.steps):
            for name in self._inputs(step):
                last_read[name] = index
        last_read[self.plan.output_name] = len(self.plan.steps)

        def shape(name):
            v = values[name]
            return (int(width * v.scale), int(height * v.scale), layers(v.channels))

        free: dict[tuple, list] = {}
        self._textures[self.plan.input_name] = self._new_texture(shape(self.plan.input_name))
        for index, step in enumerate(self.plan.steps):
            key = shape(step.output)
            texture = free[key].pop() if free.get(key) else self._new_texture(key)
            self._textures[step.output] = texture
            for name in set(self._inputs(step)):
                if last_read.get(name) == index and name != self.plan.input_name:
                    free.setdefault(shape(name), []).append(self._textures[name])
        self.size = (width, height)

    def _new_texture(self, shape):
        width, height, count = shape
        texture = self.ctx.texture_array((width, height, count), 4, dtype="f4")
        self._owned.append(texture)
        return texture

    @property
    def input_texture(self):
        return self._textures[self.plan.input_name]

    @property
    def output_texture(self):
        return self._textures[self.plan.output_name]

    # ---- running ----
    def run(self, step_timers=None) -> None:
        """All steps, on the textures of the last allocate(); `step_timers`, one context
        manager a step (passes.common.GpuTimer), times each dispatch (a benchmark's)."""
        if self.size is None:
            raise RuntimeError("allocate(width, height) first")
        width, height = self.size
        values = self.plan.values
        for index, step in enumerate(self.plan.steps):
            program = self._program(step)
            out = values[step.output]
            out_w, out_h = int(width * out.scale), int(height * out.scale)
            out_layers = layers(out.channels)
            set_uniform(program, "u_out_size", (out_w, out_h))
            set_uniform(program, "u_out_channels", out.channels)
            for unit, name in enumerate(self._inputs(step)):
                self._textures[name].bind_to_image(unit, read=True, write=False)
            self._textures[step.output].bind_to_image(7, read=False, write=True)
            z = out_layers
            if step.kind in ("conv", "conv_transpose"):
                source = values[self._inputs(step)[0]]
                set_uniform(program, "u_in_size", (int(width * source.scale), int(height * source.scale)))
                weights, bias = self._weights[id(step)]
                weights.bind_to_storage_buffer(STORAGE_BUFFERS["net_weights"])
                bias.bind_to_storage_buffer(STORAGE_BUFFERS["net_bias"])
                set_uniform(program, "u_out_layers", out_layers)
                part_layers = [layers(c) for c in step.params["part_channels"]]
                set_uniform(program, "u_part_layers", tuple(part_layers + [0] * (4 - len(part_layers))))
                kh, kw = step.params["weight"].shape[2:]
                set_uniform(program, "u_weights_per_group", sum(part_layers) * kh * kw * self.out_block)
                z = -(-out_layers // self.out_block)
            elif step.kind == "gather":
                ends = np.cumsum([values[p].channels for p in self._inputs(step)]).tolist()
                set_uniform(program, "u_part_end", tuple(ends + [ends[-1]] * (4 - len(ends))))
                set_uniform(program, "u_start", step.params["start"])
                set_uniform(program, "u_step", step.params["step"])
            elif step.kind == "resize":
                source = values[step.inputs[0]]
                in_w, in_h = int(width * source.scale), int(height * source.scale)
                set_uniform(program, "u_in_size", (in_w, in_h))
                set_uniform(program, "u_coord_x", _coordinate_map(step.params, in_w, out_w))
                set_uniform(program, "u_coord_y", _coordinate_map(step.params, in_h, out_h))
                set_uniform(program, "u_nearest_mode", NEAREST_MODES.index(step.params["nearest"]))
            columns = -(-out_w // self.pixels) if step.kind == "conv" else out_w
            if step_timers is None:
                program.run(-(-columns // LOCAL_SIZE), -(-out_h // LOCAL_SIZE), z)
            else:
                with step_timers[index]:
                    program.run(-(-columns // LOCAL_SIZE), -(-out_h // LOCAL_SIZE), z)
            # the next step reads what this one wrote through image loads
            self.ctx.memory_barrier()

    def write_input(self, x: np.ndarray) -> None:
        """(C, H, W) float32 at the allocated size into the input texture."""
        self.input_texture.write(to_layers(x).tobytes())

    def read_output(self) -> np.ndarray:
        """The output texture as (C_out, H, W) float32."""
        width, height = self.size
        count = layers(self.output_channels)
        data = np.frombuffer(self.output_texture.read(), np.float32).reshape(count, height, width, 4)
        data = data.transpose(0, 3, 1, 2).reshape(count * 4, height, width)[:self.output_channels]
        return np.ascontiguousarray(data, dtype=np.float32)

    def run_numpy(self, x: np.ndarray) -> np.ndarray:
        """(1, C, H, W) float32 of any size -> (1, C_out, H, W): padded at the bottom and right
        to the network's multiple by repeating the edge (as the onnxruntime path does), run,
        cropped."""
        x = np.asarray(x, np.float32)
        if x.ndim != 4 or x.shape[0] != 1 or x.shape[1] != self.input_channels:
            raise ValueError(f"input must be (1, {self.input_channels}, H, W), not {x.shape}")
        h, w = x.shape[2:]
        ph, pw = -h % self.multiple, -w % self.multiple
        padded = np.pad(x[0], ((0, 0), (0, ph), (0, pw)), mode="edge")
        self.allocate(w + pw, h + ph)
        self.write_input(padded)
        self.run()
        return self.read_output()[None, :, :h, :w]

    def release(self) -> None:
        self._release_textures()
        for weights, bias in self._weights.values():
            weights.release()
            bias.release()
        for program in self._programs.values():
            program.release()

    def _release_textures(self) -> None:
        for texture in self._owned:
            texture.release()
        self._owned, self._textures, self.size = [], {}, None


def to_layers(x: np.ndarray) -> np.ndarray:
    """(C, H, W) -> (ceil(C/4), H, W, 4) float32, the padded channels zero."""
    c, h, w = x.shape
    padded = np.zeros((layers(c) * 4, h, w), np.float32)
    padded[:c] = x
    return np.ascontiguousarray(padded.reshape(layers(c), 4, h, w).transpose(0, 2, 3, 1))


def _coordinate_map(params: dict, size_in: int, size_out: int) -> tuple[float, float]:
    """(a, b) with input coordinate = output coordinate * a + b (ONNX Resize's transforms)."""
    f = params["factor"]
    transform = params["transform"]
    if transform == "asymmetric":
        return (1.0 / f, 0.0)
    if transform in ("half_pixel", "pytorch_half_pixel"):
        return (1.0 / f, 0.5 / f - 0.5)
    return ((size_in - 1) / (size_out - 1) if size_out > 1 else 0.0, 0.0)  # align_corners


def set_uniform(program, name: str, value) -> None:
    member = program.get(name, None)   # the compiler drops uniforms a variant does not use
    if member is not None:
        member.value = value
