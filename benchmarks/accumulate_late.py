"""What the accumulation pass costs with paths carried into the next frame (docs/gpu.md, "How a
frame runs"): the pass alone at 1920x1080, timed by GL timer queries, as it is (`plain`),
with the late samples of the frame's tag added (`late`, what the option carry_paths=on runs), and
with the late image added and cleared by a store of zeros (`late_clear`, the clear the tag
replaced); then the renderer's own per-pass times over 32 frames without and with parking.

    python benchmarks/accumulate_late.py SCENE

Needs a GPU (the queued megakernel, where paths can be carried). Measured on an H100: 0.105 ms
plain, 0.294 clearing, 0.111 reading the late image without clearing it: the store of zeros is
what costs, hence the tag.
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene
from lift_gl import shaders
from lift_gl.passes.accumulate import SOURCE
from lift_gl.passes.common import groups
from lift_gl.report.gpu_clock import ClockReader, warm_up
from lift_gl.report.bench import PassTimer

if len(sys.argv) != 2:
    raise SystemExit(__doc__)
r = Renderer(load_scene(sys.argv[1]), size=(1920, 1080), integrator="pt", options=Options(carry_paths="on"))
clock = ClockReader(r.ctx.info.get("GL_RENDERER", ""))
warm_up(lambda: (r.render(spp=8), r.ctx.finish()), clock)
r.render(spp=4)
acc, ctx = r.accumulate, r.ctx
if getattr(r.trace, "carry", None) is None:
    raise SystemExit("no paths to carry here: the pixel queue runs on GPUs (the option pixel_queue=on elsewhere)")
late = r.trace.carry.late
q = ctx.query(time=True)
src = shaders.assemble(SOURCE, defines={"LIFT_LATE_SAMPLES": True}).text
tagged = src.replace("uniform uint u_late_frame_tag;", "uniform uint u_late_frame_tag;\nlayout(rgba32f, binding = 7) uniform image2D u_late_rw;")
variants = {
    "plain": None,
    "late": src,
    "late_clear": tagged.replace("if (imageLoad(u_late_tag, p).r == u_late_frame_tag) x += imageLoad(u_late, p);",
                                 "x += imageLoad(u_late_rw, p);\n    imageStore(u_late_rw, p, vec4(0.0));"),
}
progs = {k: (acc.program if v is None else ctx.compute_shader(v)) for k, v in variants.items()}


def run(name):
    p = progs[name]
    if name == "late":
        late.bind_to_image(5, read=True, write=False)
        r.trace.carry.late_tag.bind_to_image(6, read=True, write=False)
        p["u_late_frame_tag"].value = r.trace.carry.tag
    elif name == "late_clear":
        late.bind_to_image(7, read=True, write=True)
    r.trace.frame.bind_to_image(0, read=True, write=False)
    acc.sum.bind_to_image(1, read=True, write=True)
    acc.compensation.bind_to_image(2, read=True, write=True)
    acc.half_difference.bind_to_image(3, read=True, write=True)
    acc.moments.bind_to_image(4, read=True, write=True)
    p["u_half_sign"].value = 1.0
    p.run(*groups(1920, 1080))
    ctx.memory_barrier()


times = {k: [] for k in progs}
for rep in range(15):
    for k in (list(progs) if rep % 2 == 0 else list(progs)[::-1]):
        ctx.finish()
        with q:
            run(k)
        ctx.finish()
        times[k].append(q.elapsed / 1e6)
print("accumulate pass alone, 1080p, ms (median of 15):", {k: round(float(np.median(v)), 4) for k, v in times.items()}, "clock", clock.sm_mhz())
# the renderer's own: per pass with timers, carry on
for park in (False, True):
    r.reset()
    r.timers = {p.name: PassTimer(r.ctx) for p in r.passes}
    for i in range(32):
        r.render_frame(park=park and i < 31)
    print("park", park, {k: round(t.query.mean_ms, 4) for k, t in r.timers.items()})
    r.timers = None
