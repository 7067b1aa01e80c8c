"""benchmarks/gpu_pt_variants.py's stack variants (docs/gpu.md "A stack of node groups"): each
edit yields the stack it names, and a variant whose stack is shorter than the tree can need is
recognised (on a GPU an overflowed stack's garbage entries can loop forever: one hung the H100)."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

from lift_gl import load_scene
from lift_gl.options import Options
from lift_gl.renderer import Renderer

REPO = Path(__file__).resolve().parent.parent
_SPEC = importlib.util.spec_from_file_location("gpu_pt_variants", REPO / "benchmarks" / "gpu_pt_variants.py")
variants = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(variants)


def _stack(source):
    size = int(re.search(r"#define LIFT_BVH_STACK_SIZE (\d+)\n", source).group(1))
    depth = re.search(r"#define LIFT_BVH_SHARED_DEPTH (\d+)\n", source)
    return ("groups" if "#define LIFT_BVH_GROUP_STACK\n" in source else "children", size,
            int(depth.group(1)) if depth else None)


def test_stack_variants_and_the_too_short_ones(shared_dir):  # the dragon mesh is in ../shared
    r = Renderer(load_scene(REPO / "scenes" / "covered_dragon.toml"), size=(8, 8), integrator="pt",
                 options=Options(bvh_width="4", bvh_stack_entries="groups"))
    try:
        base, packed = r.trace.source.text, r.packed
        assert 8 < packed.bvh_levels <= 16 < packed.bvh_stack <= 48    # the 100k dragon: 15 levels, 43 pushes
        assert _stack(base) == ("groups", 16, 8)
        expected = {"groups8": ("groups", 8, None), "groups16": ("groups", 16, None),
                    "groups24_shared8": ("groups", 24, 8), "children16": ("children", 16, None),
                    "children48": ("children", 48, None)}
        for name, stack in expected.items():
            source = variants.VARIANTS[name][0](base)
            assert _stack(source) == stack, name
            assert "#define LIFT_BVH_SHARED_DEPTH LIFT_BVH_STACK" in source   # bvh.glsl's own default stays
            short = variants.stack_too_short(source, packed)
            assert (short is not None) == (name in ("groups8", "children16")), name
        assert variants.stack_too_short(base, packed) is None
    finally:
        r.release()


def test_every_pt_variant_edit_finds_its_text():
    """Each pt variant's source edit still finds the text it edits (a shader change had left
    env_uniform editing code that no longer existed: the variant then failed on the GPU machine).
    The showcase has an environment map and textures, which those edits need."""
    r = Renderer(load_scene(REPO / "scenes" / "showcase.toml"), size=(8, 8), integrator="pt")
    try:
        base = r.trace.source.text
        for name, (edit, _, _) in variants.VARIANTS.items():
            if edit is not None and not name.startswith("bdpt"):
                assert isinstance(edit(base), str), name   # _sub raises where its text is missing
    finally:
        r.release()


def test_settings_reach_every_variant():
    """--set rr_depth=1 (Lift's roulette): the variants run with it, so the counted rays a
    pixel fall against the default's (roulette from the fourth bounce)."""
    from lift_gl.gl.context import create_context

    ctx = create_context("auto")
    counts = {}
    for label, settings in (("default", None), ("rr1", {"rr_depth": "1", "rr_min_survival": "0"})):
        res = variants.run_scene(ctx, str(REPO / "scenes" / "cornell.toml"), (32, 24), 8, ["base", "count_rays"], 1,
                                 None, settings=settings)
        counts[label] = sum(res["variants"]["count_rays"]["mean_counts_rgb"])
    assert counts["rr1"] < 0.8 * counts["default"]


def test_noshadow_unblocks_shadow_rays_in_the_paired_loop():
    """noshadow must reach the shadow rays that trace_shadow_and_next traces with the next ray
    (LIFT_TRACE_PAIRED, forced on here): with every shadow ray unblocked the box's shadowed
    floor gets light, so the image is brighter than the base's."""
    from lift_gl.gl.context import create_context

    ctx = create_context("auto")
    res = variants.run_scene(ctx, str(REPO / "scenes" / "cornell.toml"), (32, 24), 4, ["base", "noshadow"], 1, None,
                             options=Options(trace_paired="on"))
    assert res["variants"]["noshadow"]["mean_rgb"] > 1.02 * res["variants"]["base"]["mean_rgb"]


def test_queue_spread_takes_every_pixel_once_and_an_unwritten_pixel_shows(monkeypatch):
    """The queue_spread variants (k counters) give the base's image exactly; a variant that
    skips pixels is caught, as the harness fills the frame with NaN before each image."""
    from lift_gl.gl.context import create_context

    monkeypatch.setitem(variants.VARIANTS, "skips", (lambda text: variants._sub(
        text, "uint item = atomicAdd(lift_queue_next, 1u);", "uint item = 2u * atomicAdd(lift_queue_next, 1u);"), {}, True))
    ctx = create_context("auto")
    res = variants.run_scene(ctx, str(REPO / "scenes" / "cornell.toml"), (40, 24), 4,
                             ["base", "queue_spread4", "queue_spread64", "skips"], 1, None,
                             options=Options(pixel_queue="on"))
    v = res["variants"]
    assert v["queue_spread4"]["max_abs_diff_vs_first"] == 0 and v["queue_spread64"]["max_abs_diff_vs_first"] == 0
    assert not v["skips"]["finite"]


def test_tree_variant_of_this_checkout_is_the_base_program():
    """`tree` (another checkout's plugin built as this renderer builds its own) must use the
    megakernel's own defines: built from this very checkout it is the base program, pixel queue
    on or off. (It took the renderer's defines before, which lack the pixel queue: on the H100
    pt's old code then ran 0.54-0.94x, a false A/B.)"""
    for queue in ("off", "on"):
        r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(8, 8), integrator="pt",
                     options=Options(pixel_queue=queue))
        try:
            assert ("#define LIFT_PIXEL_QUEUE" in r.trace.source.text) == (queue == "on")
            assert variants.tree_plugin_source(r, REPO) == r.trace.source.text, queue
        finally:
            r.release()


def test_live_state_variants_keep_the_image():
    """The tenth session's register-pressure variants (state moved to shared memory, the
    camera ray made again, floats added to what lives across the traversal) change the program,
    not the image, with the pixel queue on (their edits are in its loop)."""
    from lift_gl.gl.context import create_context

    options = Options(pixel_queue="on", trace_paired="on")
    names = ["base", "regen_primary", "pending_shared", "live_plus8"]
    base_text = None
    r = Renderer(load_scene(REPO / "scenes" / "cornell.toml"), size=(8, 8), integrator="pt", options=options)
    try:
        base_text = r.trace.source.text
        for name in names[1:]:
            assert variants.VARIANTS[name][0](base_text) != base_text, name
    finally:
        r.release()
    ctx = create_context("auto")
    res = variants.run_scene(ctx, str(REPO / "scenes" / "cornell.toml"), (40, 24), 4, names, 1, None, options=options)
    v = res["variants"]
    for name in names[1:]:
        assert v[name]["finite"] and v[name]["max_abs_diff_vs_first"] == 0, name


def test_const_params_makes_the_plugin_settings_constants():
    """const_params turns pt's parameter uniforms into constants of this run's values, and the
    image stays the same (the queue on, as on GPUs)."""
    from lift_gl.gl.context import create_context

    ctx = create_context("auto")
    res = variants.run_scene(ctx, str(REPO / "scenes" / "cornell.toml"), (40, 24), 5, ["base", "const_params"], 1, None,
                             settings={"rr_depth": 2}, options=Options(pixel_queue="on"))
    assert res["variants"]["const_params"]["max_abs_diff_vs_first"] == 0
    edited = variants.const_params("uniform int max_depth;  // x\\nuniform int rr_depth;  // y\\n")
    assert "const int max_depth = 5;" in edited and "const int rr_depth = 2;" in edited


def test_tile_orders_put_the_most_work_first():
    """queue_order_ variants' orders (docs/gpu.md "Twelfth session"): tiles by their mean
    1 / (1 - albedo), a camera ray that left the scene counting as no work; the control is the
    reverse, identity the queue's own row-by-row numbering."""
    import numpy as np

    albedo = np.zeros((4, 16, 4), np.float32)          # 2 x 2 tiles of 8x2
    albedo[0:2, 0:8] = (0.5, 0.2, 0.1, 1.0)            # tile 0: 1 / 0.5 = 2
    albedo[0:2, 8:16] = (0.99, 0.99, 0.99, 1.0)        # tile 1: capped at 0.95 -> 20
    albedo[2:4, 8:16] = (0.0, 0.0, 0.0, 1.0)           # tile 3: a black hit -> 1; tile 2: misses -> 0
    orders = variants.tile_orders(albedo, (8, 2))
    assert orders["queue_order_long_first"].tolist() == [1, 0, 3, 2]
    assert orders["queue_order_short_first"].tolist() == [2, 3, 0, 1]
    assert orders["queue_order_identity"].tolist() == [0, 1, 2, 3]
