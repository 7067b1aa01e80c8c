"""Scenes split across several storage buffers (lift_gl/scene/split.py): the heap holds every
array exactly, and a split scene renders the very image the unsplit one does (same driver,
same seed: the shaders read the same numbers through the heap accessors)."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import REPO
from lift_gl.options import Options
from lift_gl.renderer import Renderer
from lift_gl.scene.loader import load_scene
from lift_gl.scene.pack import pack_scene
from lift_gl.scene.split import HEAP_ARRAYS, MAX_HEAP_CHUNKS, ROW_BYTES, heap_chunks, heap_rows_of, plan_buffers


def _small_limit(packed) -> int:
    """A per-buffer limit (bytes) just below the largest heap array: the scene must split."""
    largest = max(heap_rows_of(getattr(packed, n)).shape[0] for n in HEAP_ARRAYS)
    return (1 << int(np.floor(np.log2(largest - 1)))) * ROW_BYTES


def _small_showcase():
    """showcase.toml (a textured floor) with its texture cut to 8x8 and a constant sky, so
    that the images buffer (never split) fits under the small limit."""
    import dataclasses

    scene = load_scene(REPO / "scenes" / "showcase.toml")
    textures = [dataclasses.replace(t, pixels=np.ascontiguousarray(t.pixels[::16, ::16])) for t in scene.textures]
    env = dataclasses.replace(scene.environment, image=None)
    return dataclasses.replace(scene, textures=textures, environment=env)


def test_heap_holds_every_array_exactly():
    packed = pack_scene(load_scene(REPO / "scenes" / "cornell.toml"))
    assert plan_buffers(packed, 1 << 30).split is False   # fits: no heap
    plan = plan_buffers(packed, _small_limit(packed) + 7)   # not a power of two of rows
    assert plan.split and 2 <= plan.chunks <= MAX_HEAP_CHUNKS
    chunks = list(heap_chunks(packed, plan))
    assert all(c.nbytes <= _small_limit(packed) for c in chunks)
    heap = np.concatenate(chunks)
    assert heap.shape[0] == plan.heap_rows
    for name in HEAP_ARRAYS:
        rows = heap_rows_of(getattr(packed, name))
        got = heap[plan.bases[name]:plan.bases[name] + rows.shape[0]]
        np.testing.assert_array_equal(got.view(np.uint32), rows.view(np.uint32))   # bit-exact


@pytest.mark.parametrize("scene_name, integrator, aov", [
    ("cornell.toml", "pt", None),        # emissive triangles: light sampling reads the heap
    ("showcase.toml", "pt", None),       # a textured floor: uvs from the heap
    ("cornell.toml", "drt", None),       # camera rays (no G-buffer): every hit from the heap
    ("cornell.toml", "pt", "normal"),    # the G-buffer's vertex shader reads the heap
])
def test_split_scene_renders_the_same_image(scene_name, integrator, aov):
    scene = _small_showcase() if scene_name == "showcase.toml" else load_scene(REPO / "scenes" / scene_name)
    size = (40, 32)

    def render(options=None):
        r = Renderer(scene, size=size, integrator=integrator, seed=3, options=options)
        try:
            image = r.aov(aov) if aov else r.render(spp=4)
            return image, r.buffers.plan, r.explain()
        finally:
            r.release()

    whole, plan, _ = render()
    assert not plan.split
    split, plan, explain = render(Options(max_buffer_bytes=_small_limit(pack_scene(scene))))
    assert plan.split and plan.chunks >= 4, plan
    assert "heap[3]" in explain and "split into" in explain
    assert np.isfinite(whole).all() and whole.max() > 0
    np.testing.assert_array_equal(split, whole)


def test_scene_edit_moves_between_split_and_whole():
    """The viewer's live edits re-pack the scene: when the heap's chunk count changes the
    shaders are recompiled, and the image is the one a fresh renderer gives."""
    import dataclasses

    scene = load_scene(REPO / "scenes" / "cornell.toml")
    packed = pack_scene(scene)
    # just enough for the largest array: whole now, split once triangles are added
    limit = Options(max_buffer_bytes=max(getattr(packed, n).nbytes for n in HEAP_ARRAYS))
    r = Renderer(scene, size=(32, 32), seed=1, options=limit)
    before = r.buffers.plan.chunks
    assert before == 0
    extra = [dataclasses.replace(m, positions=m.positions * 0.3 + [0.1, 0.2, 0.1]) for m in scene.meshes[:4]]
    bigger = dataclasses.replace(scene, meshes=[*scene.meshes, *extra])
    r.update_scene(bigger)
    assert 2 <= r.buffers.plan.chunks <= MAX_HEAP_CHUNKS
    assert r.defines["LIFT_HEAP_CHUNKS"] == r.buffers.plan.chunks
    image = r.render(spp=2)
    fresh = Renderer(bigger, size=(32, 32), seed=1)
    np.testing.assert_array_equal(image, fresh.render(spp=2))
    r.release()
    fresh.release()
