"""The frame graph (lift_gl/passes/graph.py): passes ordered, made and explained from their
declarations; optional ports; passes the asked resources do not need are not made. Then the
renderer's own frames (lift_gl/frame_passes.py) for its settings."""
from __future__ import annotations

import pytest

from conftest import REPO
from lift_gl.passes.graph import FrameGraph, GraphError, Node, Port, plan


def declared(name, inputs=(), outputs=()):
    """A pass class declaring these ports; its instances count their releases."""
    return type(name, (), {"name": name, "inputs": tuple(inputs), "outputs": tuple(outputs),
                           "released": 0, "release": lambda self: setattr(self, "released", self.released + 1)})


def node(name, inputs=(), outputs=(), made=None, **kw):
    kind = declared(name, inputs, outputs)

    def make():
        if made is not None:
            made.append(name)
        return kind()
    return Node(name, kind, make, **kw)


# A frame of the renderer's shape: G-buffer, trace, a pass that changes the frame in place,
# reprojection from the previous frame's accumulation, accumulation, and the on-demand ones.
def frame(made=None, reproject=True, gbuffer_primary=True):
    return [node("gbuffer", ("scene", "camera", "jitter"), ("visibility", "normal_depth", "albedo", "motion?"),
                 made, uses=("motion",) if reproject else ()),
            node("trace", ("scene", "camera", "visibility?"), ("frame",), made,
                 uses=("visibility",) if gbuffer_primary else ()),
            *([node("upsample", ("frame", "normal_depth"), ("frame",), made)] if gbuffer_primary else []),
            *([node("reproject", ("previous accumulation", "normal_depth", "previous normal_depth", "motion", "frame"),
                    ("history",), made)] if reproject else []),
            node("accumulate", ("frame", "history?"), ("accumulation", "half difference"), made,
                 uses=("history",) if reproject else ()),
            node("denoise", ("accumulation", "half difference", "albedo", "normal_depth"), ("denoised",), made),
            node("tonemap", ("accumulation", "denoised?"), ("display",), made)]


def names(nodes):
    return [n.name for n in nodes]


def test_ports_parse_as_declared():
    assert Port.parse("visibility?") == Port("visibility", optional=True)
    assert Port.parse("previous normal_depth") == Port("normal_depth", previous=True)
    assert Port.parse("frame (with splats)") == Port("frame", note="with splats")
    assert Port.parse("half difference") == Port("half difference")
    assert Port.parse("frame (with splats)").text() == "frame (with splats)"
    with pytest.raises(GraphError):
        Port.parse("(nothing)")


def test_order_maker_then_changers_then_readers():
    # listed backwards: only the declarations order them
    order = names(plan(list(reversed(frame())), ("accumulation",)))
    assert order.index("gbuffer") < order.index("trace") < order.index("upsample") < order.index("reproject")
    assert order.index("reproject") < order.index("accumulate")
    # the previous frame's accumulation orders nothing: reproject runs before accumulate
    assert set(order) == {"gbuffer", "trace", "upsample", "reproject", "accumulate"}


def test_unconstrained_passes_keep_the_order_given():
    a, b = node("a", (), ("x",)), node("b", (), ("y",))
    assert names(plan([a, b], ("x", "y"))) == ["a", "b"]
    assert names(plan([b, a], ("x", "y"))) == ["b", "a"]


def test_only_the_passes_the_asked_resources_need_are_made():
    made = []
    graph = FrameGraph(frame(made), ("accumulation",))
    assert made == ["gbuffer", "trace", "upsample", "reproject", "accumulate"]
    assert "denoise" not in graph and graph.get("tonemap") is None
    graph.ask("display")   # the screen: the tone mapper only, no denoiser
    assert made[-1] == "tonemap" and "denoise" not in graph
    graph.ask("display")   # asked once: nothing more made
    assert made.count("tonemap") == 1


def test_optional_inputs_pull_their_maker_only_where_used():
    # a plugin that traces its own camera rays, without reprojection: no G-buffer in its frames
    made = []
    graph = FrameGraph(frame(made, reproject=False, gbuffer_primary=False), ("accumulation",))
    assert "gbuffer" not in made and "reproject" not in made
    # ... until the denoiser wants its guides: made then, but not run every frame
    graph.ask("denoised")
    assert "gbuffer" in graph and "denoise" in graph
    assert not graph.per_frame("gbuffer") and graph.per_frame("trace") and not graph.per_frame("denoise")
    # with the G-buffer primary hit, it runs every frame
    primary = FrameGraph(frame(reproject=False), ("accumulation",))
    assert primary.per_frame("gbuffer")


def test_optional_outputs_are_made_only_where_used():
    g = frame(reproject=False)[0]
    assert [p.resource for p in g.ports()[1]] == ["visibility", "normal_depth", "albedo"]
    assert [p.resource for p in frame()[0].ports()[1]][-1] == "motion"
    with pytest.raises(GraphError, match="no optional port"):
        node("x", ("a",), ("b",), uses=("a",)).ports()
    # reprojection reads the motion vectors: a G-buffer that does not make them cannot feed it
    nodes = frame()
    nodes[0] = node("gbuffer", ("scene",), ("visibility", "normal_depth", "albedo", "motion?"))
    with pytest.raises(GraphError, match="no pass makes 'motion'"):
        plan(nodes, ("accumulation",))


def test_bad_graphs_are_refused():
    with pytest.raises(GraphError, match="no pass makes 'frame'"):
        plan([node("accumulate", ("frame",), ("accumulation",))], ("accumulation",))
    with pytest.raises(GraphError, match="made by two passes"):
        plan([node("a", (), ("x",)), node("b", (), ("x",))], ("x",))
    with pytest.raises(GraphError, match="cycle"):
        plan([node("a", ("y",), ("x",)), node("b", ("x",), ("y",))], ("x",))
    with pytest.raises(GraphError, match="asked for"):
        plan(frame(), ("nothing",))


def test_explain_prints_the_declarations():
    graph = FrameGraph(frame(), ("accumulation", "denoised"))
    lines = graph.explain()
    assert [line.split()[0] for line in lines] == ["gbuffer", "trace", "upsample", "reproject", "accumulate",
                                                   "denoise"]
    assert "  trace       scene, camera, visibility -> frame" in lines
    assert any(line.startswith("  reproject   previous accumulation, normal_depth, previous normal_depth, motion, "
                               "frame -> history") for line in lines)
    assert lines[-1].endswith("-> denoised [on demand]")
    # a made pass's own declarations win (a note of what its settings add), and `why` is printed
    nodes = frame(reproject=False)
    nodes[1].why = lambda made: f"runs {type(made).__name__}"
    graph = FrameGraph(nodes, ("accumulation",))
    graph.get("trace").outputs = ("frame (with splats)",)
    assert "  trace       scene, camera, visibility -> frame (with splats): runs trace" in graph.explain()


def test_rebuild_keeps_remakes_and_releases():
    made = []
    graph = FrameGraph(frame(made), ("accumulation", "denoised"))
    old = dict(graph.made)
    made.clear()
    graph.rebuild(frame(made, reproject=False), remake={"trace"})
    assert made == ["trace"]   # the others are still needed and kept
    assert old["trace"].released == 1 and old["reproject"].released == 1   # no longer needed
    assert graph.get("gbuffer") is old["gbuffer"] and old["gbuffer"].released == 0
    made.clear()
    graph.rebuild(remake=True)   # a new size: every pass anew
    assert made == ["gbuffer", "trace", "upsample", "accumulate", "denoise"]
    assert old["gbuffer"].released == 1


def test_a_rebuild_that_fails_changes_nothing():
    graph = FrameGraph(frame(), ("accumulation",))
    before = dict(graph.made)
    nodes, tried = frame(), []

    def gbuffer():
        tried.append(nodes[0].kind())
        return tried[-1]

    def broken():
        raise GraphError("does not compile")
    nodes[0] = Node("gbuffer", nodes[0].kind, gbuffer, uses=("motion",))
    nodes[1] = Node("trace", nodes[1].kind, broken, uses=("visibility",))
    with pytest.raises(GraphError, match="does not compile"):
        graph.rebuild(nodes, remake={"gbuffer", "trace"})
    assert graph.made == before and all(p.released == 0 for p in before.values())
    assert len(tried) == 1 and tried[0].released == 1   # the new G-buffer made before the failure: released


def test_swap_and_release():
    graph = FrameGraph(frame(), ("accumulation",))
    old = graph.get("trace")
    replacement = graph.node("trace").kind()
    assert graph.swap("trace", replacement) is old and graph.get("trace") is replacement
    passes = graph.passes
    graph.release()
    assert all(p.released == 1 for p in passes) and graph.passes == []


def test_on_make_sees_every_pass_made():
    seen = []
    graph = FrameGraph(frame(), ("accumulation",), on_make=lambda name, made: seen.append(name))
    graph.ask("display")
    assert seen == ["gbuffer", "trace", "upsample", "reproject", "accumulate", "tonemap"]


# ---- the renderer's frames ----
CORNELL = REPO / "scenes" / "cornell.toml"


@pytest.fixture(scope="module")
def cornell():
    from lift_gl import load_scene

    return load_scene(CORNELL)


def frame_of(scene, **kw):
    from lift_gl.renderer import Renderer

    r = Renderer(scene, size=(8, 6), **kw)
    try:
        return [p for p in r.graph.made], {name: r.graph.per_frame(name) for name in r.graph.made}, r.explain()
    finally:
        r.release()


def test_the_renderers_frame_for_its_settings(cornell):
    from lift_gl.frame_settings import DenoiseSettings

    order, per_frame, _ = frame_of(cornell)
    assert order == ["gbuffer", "trace", "accumulate"] and all(per_frame.values())
    order, _, _ = frame_of(cornell, integrator="drt")   # its own camera rays: no G-buffer
    assert order == ["trace", "accumulate"]
    order, per_frame, text = frame_of(cornell, integrator="drt", denoise=DenoiseSettings("final"))
    assert order == ["gbuffer", "trace", "accumulate", "denoise"]
    assert not per_frame["gbuffer"] and "gbuffer     scene, camera, jitter -> visibility, normal_depth, albedo " \
                                       "[on demand]: the denoiser's guides" in text
    order, per_frame, text = frame_of(cornell, temporal="reproject")
    assert order == ["gbuffer", "trace", "reproject", "accumulate"] and all(per_frame.values())
    assert "-> visibility, normal_depth, albedo, motion: the reproject pass needs" in text
    assert "accumulate  frame, history -> accumulation, half difference, moments" in text
    order, _, _ = frame_of(cornell, integrator="hybrid")
    assert order == ["gbuffer", "trace", "reduced", "upsample", "accumulate"]


def test_explain_lists_the_graphs_passes_from_their_declarations(cornell):
    from lift_gl.renderer import Renderer

    r = Renderer(cornell, size=(8, 6), integrator="bdpt")
    r.display()
    text = r.explain()
    lines = text.splitlines()
    start = lines.index("passes (inputs -> outputs, from each pass's declarations):")
    assert lines[start + 1:start + 1 + len(r.passes)] == r.graph.explain()
    assert "  trace       scene, camera, visibility, prepass -> frame (with splats): runs bdpt.glsl" in text   # its splats, its light subpaths
    assert "tonemap     accumulation -> display [on demand]" in text
    r.release()
