"""How many nodes of the 4-wide BVH a ray visits: each ray traversed on its own as
shaders/lift/bvh.glsl traverses it (a stack; a node's hit children near to far; the closest hit,
or for shadow rays the first hit found), emulated in numpy, next to the fewest any traversal
must visit (the wide nodes whose box the ray crosses before its hit). The tree is the
renderer's (scene/pack.py, 4-wide, splits as $LIFT_GL_BVH_SPLITS says).

    python benchmarks/bvh_visits.py SCENE... [--rays 1000] [--seed 1] [--json FILE]

Ray kinds: camera rays over a 16:9 image, bounce rays (cosine-distributed about the geometric
normal at the camera rays' hits) and shadow rays from those hits, towards the scene's distant
lights where it has some, else in cosine-distributed directions of unbounded length (an
environment light's); for these the fewest nodes are those before the nearest hit (a
closest-hit query's least), which an any-hit query may undercut by stopping at a farther one.
A GPU runs 32 rays in lockstep: the "warp" column is the busiest lane's count in warps of 32
random rays of a kind (warp_nodes); the second table runs the bounce rays of 8x4 pixel tiles,
as the trace pass groups them, in lockstep (tile_bounce_warps: the steps a warp takes, the
lanes busy and the distinct fetches a step). What it tells: whether a scene's rays are slow because they visit many
nodes (the tree, the traversal order) or because each visit costs more (memory): a GPU's
Mrays/s (benchmarks/gpu.py) divided into these counts. Needs no GPU.

A tree for a distant light's shadow rays: `--light-frame` builds a second tree over the scene
turned so that its first distant light lies along +z and runs the shadow rays towards it
through both (on the dining room the sun-frame tree makes them visit more nodes, not fewer;
what the sun's shadow rays cost: docs/gpu.md, "Measuring").

    python benchmarks/bvh_visits.py SCENE --light-frame [--rays 3000] [--json FILE]

Where the slow rays are: `--heatmap FILE.png` traces a camera ray and a bounce ray from every
pixel of a `--heat-size` image and writes their node visits side by side (black, red, yellow:
0 to the larger of the two 99th percentiles), and prints which materials' leaves the bounce
rays visit, all of them against the slowest 2% (on the dining room: its slanted chrome tubes,
docs/bvh.md "Split references").

    python benchmarks/bvh_visits.py SCENE --rays 0 --heatmap heat.png [--heat-size 192x108]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from gpu import scene_name  # noqa: E402
from lift_gl.accel.bvh import _safe_inv, moller_trumbore  # noqa: E402
from lift_gl.accel.wide import COUNT_SHIFT, LEAF_BIT, MAX_FIRST, MAX_LEAF_COUNT, WideBVH, decoded_boxes  # noqa: E402
from lift_gl.report.records import write_json  # noqa: E402

T_EPS = 1e-6   # a hit nearer than this along the ray is the surface the ray leaves


class WideTree:
    """The packed 4-wide tree's child boxes and entries, and its triangles in leaf order (float64)."""

    def __init__(self, packed):
        if packed.bvh_width != 4:
            raise ValueError("the scene packed without a 4-wide tree (motion blur, instances or $LIFT_GL_BVH_WIDTH=2)")
        wide = WideBVH(rows=packed.bvh_nodes, width=4, stack_bound=packed.bvh_stack, quantized=packed.bvh_quantized,
                       levels=packed.bvh_levels)
        lo, hi, entry = decoded_boxes(wide)
        self.lo, self.hi = lo.astype(np.float64), hi.astype(np.float64)
        self.entry = entry.astype(np.int64)
        self.tris = packed.tri_pos[:packed.num_triangles, :, :3].astype(np.float64)

    def slots(self, node: int, o, inv, t_max: float):
        """Entry distances of node's four children and which the ray (0, t_max) enters."""
        t0 = (self.lo[node] - o) * inv
        t1 = (self.hi[node] - o) * inv
        near = np.where(inv >= 0, t0, t1).max(axis=1)
        far = np.where(inv >= 0, t1, t0).min(axis=1)
        return near, np.maximum(near, 0.0) <= np.minimum(far, t_max)

    def leaf(self, entry: int, o, d):
        """Distances of the leaf's triangles hit by the ray (inf where missed), and how many."""
        count = ((entry >> COUNT_SHIFT) & (MAX_LEAF_COUNT - 1)) + 1
        first = entry & (MAX_FIRST - 1)
        tri = self.tris[first:first + count]
        t, _, _, ok = moller_trumbore(tri[:, 0], tri[:, 1], tri[:, 2], np.repeat(o[None], count, 0),
                                      np.repeat(d[None], count, 0))
        return np.where(ok & (t > T_EPS), t, np.inf), first, count


class CollapsedTree(WideTree):
    """A tree of `width` children a node, collapsed from the binary tree of a scene packed with
    bvh_width=2 (each node's interior child of largest area opened until it has `width`, as
    accel/wide.py's greedy collapse does to 4; the renderer's default collapse chooses by cost,
    accel/wide_sah.py), with WideTree's arrays, so that traverse() and the lockstep
    measures run on it: what wider nodes would save in visits and warp steps before any shader
    is written for them (`--widths`)."""

    def __init__(self, packed, width: int):
        if packed.bvh_width != 2:
            raise ValueError("collapse a scene packed with bvh_width=2")
        rows = packed.bvh_nodes
        words = rows.view(np.uint32)
        lo, hi = rows[:, 0:3].astype(np.float64), rows[:, 4:7].astype(np.float64)
        first, count = words[:, 3].astype(np.int64), words[:, 7].astype(np.int64)
        extent = hi - lo
        area = extent[:, 0] * extent[:, 1] + extent[:, 1] * extent[:, 2] + extent[:, 2] * extent[:, 0]
        children = []                     # per wide node: its binary children
        index = {0: 0}
        pending = [0]
        while pending:
            node = pending.pop(0)
            kids = [node] if count[node] else [int(first[node]), int(first[node]) + 1]
            while len(kids) < width and any(count[k] == 0 for k in kids):
                k = max((k for k in kids if count[k] == 0), key=lambda k: area[k])
                kids.remove(k)
                kids += [int(first[k]), int(first[k]) + 1]
            children.append(kids)
            for k in kids:
                if count[k] == 0:
                    index[k] = len(index)
                    pending.append(k)
        m = len(children)
        self.lo = np.full((m, width, 3), np.inf)
        self.hi = np.full((m, width, 3), -np.inf)      # empty slots: boxes no ray enters
        self.entry = np.zeros((m, width), np.int64)
        for w, kids in enumerate(children):
            for i, k in enumerate(kids):
                self.lo[w, i], self.hi[w, i] = lo[k], hi[k]
                self.entry[w, i] = (LEAF_BIT | ((int(count[k]) - 1) << COUNT_SHIFT) | int(first[k])) if count[k] \
                    else index[k]
        self.tris = packed.tri_pos[:packed.num_triangles, :, :3].astype(np.float64)


def traverse(tree: WideTree, o, d, any_hit: bool = False, t_max: float = np.inf, steps: list | None = None) -> dict:
    """One ray through the tree as the GLSL traversal goes (children near to far, the nearest
    next): its hit (t, row) and the wide nodes, leaves and triangles it visited; `steps`, if
    given, gets each visit in order (("node", id) or ("leaf", first row))."""
    inv = _safe_inv(d[None])[0]
    t, row = t_max, -1
    stack, nodes, leaves, triangles = [0], 0, 0, 0
    while stack:
        entry = stack.pop()
        if entry & LEAF_BIT:
            hits, first, count = tree.leaf(entry, o, d)
            leaves, triangles = leaves + 1, triangles + count
            if steps is not None:
                steps.append(("leaf", first))
            k = int(np.argmin(hits))
            if hits[k] < t:
                t, row = float(hits[k]), first + k
                if any_hit:
                    break
            continue
        nodes += 1
        if steps is not None:
            steps.append(("node", entry))
        near, hit = tree.slots(entry, o, inv, t)
        order = [i for i in np.argsort(near, kind="stable") if hit[i]]
        stack.extend(int(tree.entry[entry, i]) for i in reversed(order))   # the nearest on top
    return {"t": t, "row": row, "nodes": nodes, "leaves": leaves, "triangles": triangles}


def fewest_nodes(tree: WideTree, o, d, t_end: float) -> int:
    """The wide nodes whose box the segment (0, t_end) crosses: what any traversal that finds
    the hit at t_end must visit (the root, and every interior child entered before t_end)."""
    inv = _safe_inv(d[None])[0]
    level, count = [0], 0
    while level:
        count += len(level)
        nxt = []
        for node in level:
            _, hit = tree.slots(node, o, inv, t_end)
            nxt += [int(e) for e, h in zip(tree.entry[node], hit) if h and not e & LEAF_BIT]
        level = nxt
    return count


def warp_nodes(nodes: np.ndarray, rng, lanes: int = 32, draws: int = 4000) -> float:
    """The mean over warps of their busiest lane's node visits, for warps of `lanes` rays drawn
    at random from these: what a while-while loop on a SIMT GPU runs (its lanes step together
    until the last is done) for incoherent rays; nodes.mean() / this is its SIMD efficiency.
    (Neighbouring camera rays are more alike than random ones: for them it is an upper bound.)"""
    return float(np.mean([rng.choice(nodes, lanes).max() for _ in range(draws)]))


def lockstep(sequences: list) -> dict:
    """A warp's lanes stepping together through their visit sequences (traverse's `steps`), a
    visit a step, until the longest is done: the steps, and per step the lanes still busy and the
    distinct nodes or leaves they fetch (lanes at one node share a fetch)."""
    steps = max(len(q) for q in sequences)
    busy = distinct = 0
    for k in range(steps):
        now = [q[k] for q in sequences if k < len(q)]
        busy += len(now)
        distinct += len(set(now))
    return {"steps": steps, "busy_per_step": busy / steps, "fetches_per_step": distinct / steps}


def tile_bounce_warps(scene, packed, tree: WideTree, tiles: int, rng, size=(1920, 1080), tile=(8, 4)) -> dict:
    """Warps as the trace pass forms them: the bounce rays (cosine-distributed) from the camera
    rays' hits of `tiles` random 8x4 pixel tiles of a `size` image, run in lockstep (tiles where
    fewer than half the camera rays hit are skipped). Means over the tiles of lockstep()."""
    camera = packed.to_gpu_camera(scene.camera)
    right, up, forward = camera.basis()
    h = np.tan(np.radians(camera.fov_deg) / 2)
    (w_px, h_px), (tx, ty) = size, tile
    results = []
    for _ in range(tiles):
        x0, y0 = rng.integers(0, w_px - tx), rng.integers(0, h_px - ty)
        px = np.array([(x0 + i, y0 + j) for j in range(ty) for i in range(tx)], np.float64)
        ndc = (px + 0.5) / np.array([w_px, h_px]) * 2 - 1
        d = forward[None] + ndc[:, :1] * h * w_px / h_px * right[None] + ndc[:, 1:] * h * up[None]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        sequences = []
        for di in d:
            first = traverse(tree, camera.position, di)
            if first["row"] < 0:
                continue
            steps = []
            bounce_from(tree, camera.position, di, first, rng, steps)
            sequences.append(steps)
        if 2 * len(sequences) >= tx * ty:
            results.append(lockstep(sequences))
    if not results:
        return {"tiles": 0}
    return {"tiles": len(results), **{k: float(np.mean([r[k] for r in results])) for k in results[0]}}


def bounce_from(tree: WideTree, origin, d, first: dict, rng, steps: list | None = None) -> dict:
    """The bounce ray from the hit `first` (traverse's result) of the ray (origin, d): cosine-
    distributed about the hit triangle's geometric normal on the side the ray came from,
    traversed; traverse's result for it."""
    tri = tree.tris[first["row"]]
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    n = n / (np.linalg.norm(n) + 1e-300) * -np.sign(n @ d)
    p = origin + first["t"] * d
    start = p + n * 1e-4 * max(1.0, float(np.abs(p).max()))
    return traverse(tree, start, _cosine_about(n[None], rng)[0], steps=steps)


def _cosine_about(n: np.ndarray, rng) -> np.ndarray:
    v = rng.standard_normal(n.shape)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v = n + v
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def scene_rays(scene, packed, tree: WideTree, n: int, rng) -> dict:
    """{kind: (origins, directions, any_hit)}: camera, bounce and shadow rays (module docstring)."""
    camera = packed.to_gpu_camera(scene.camera)
    right, up, forward = camera.basis()
    h = np.tan(np.radians(camera.fov_deg) / 2)
    x = (rng.random(n) * 2 - 1) * h * 16 / 9
    y = (rng.random(n) * 2 - 1) * h
    d = forward[None] + x[:, None] * right[None] + y[:, None] * up[None]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.repeat(camera.position[None], n, 0)
    first = [traverse(tree, o[i], d[i]) for i in range(n)]
    hit = np.array([r["row"] >= 0 for r in first])
    t = np.array([r["t"] for r in first])[hit]
    p = o[hit] + t[:, None] * d[hit]
    tri = tree.tris[np.array([r["row"] for r in first])[hit]]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-300
    normal *= -np.sign((normal * d[hit]).sum(axis=1))[:, None]   # the side the camera ray came from
    start = p + normal * 1e-4 * max(1.0, float(np.abs(p).max()))
    rays = {"camera": (o, d, False), "bounce": (start, _cosine_about(normal, rng), False)}
    lights = [light.direction for light in scene.distant_lights]
    if lights:
        towards = np.array(lights, np.float64)[np.arange(len(start)) % len(lights)]
        facing = (towards * normal).sum(axis=1) > 0
        rays["shadow"] = (start[facing], towards[facing], True)
    else:
        rays["shadow"] = (start, _cosine_about(normal, rng), True)
    return rays


def pixel_visits(scene, packed, tree: WideTree, size, rng, slowest: float = 0.02) -> dict:
    """Per pixel of a `size` (W, H) image: the nodes its camera ray and a bounce ray from the
    camera ray's hit (cosine-distributed about the geometric normal) visit, (H, W) arrays
    ('camera', 'bounce'; 0 where the camera ray misses), and the leaf visits of the bounce rays
    by material ({material: (share of all bounce rays' leaf visits, share of the `slowest`
    fraction's)}, the slowest by node visits)."""
    from lift_gl.app.scene_editor import camera_ray

    camera = packed.to_gpu_camera(scene.camera)
    w_px, h_px = size
    cam = np.zeros((h_px, w_px), np.int64)
    bounce = np.zeros((h_px, w_px), np.int64)
    material = packed.tri_info[:packed.num_triangles, 0].astype(np.int64)
    leaf_materials = []                     # per bounce ray: the material of each leaf it visits
    for j in range(h_px):
        for i in range(w_px):
            origin, d = camera_ray(camera, size, (i, j))
            first = traverse(tree, origin, d)
            cam[j, i] = first["nodes"]
            if first["row"] < 0:
                continue
            steps = []
            bounce[j, i] = bounce_from(tree, origin, d, first, rng, steps)["nodes"]
            leaf_materials.append((bounce[j, i], [int(material[row]) for kind, row in steps if kind == "leaf"]))
    names = {k: getattr(m, "name", None) or f"#{k}" for k, m in enumerate(scene.materials)}
    shares = {}
    if leaf_materials:
        cut = np.quantile([n for n, _ in leaf_materials], 1.0 - slowest)
        every = np.bincount([m for _, ms in leaf_materials for m in ms], minlength=len(names))
        slow = np.bincount([m for n, ms in leaf_materials if n >= cut for m in ms], minlength=len(names))
        shares = {names.get(k, f"#{k}"): (float(every[k] / max(every.sum(), 1)), float(slow[k] / max(slow.sum(), 1)))
                  for k in np.argsort(-every) if every[k] or slow[k]}
    return {"camera": cam, "bounce": bounce, "materials": shares}


def heat_image(visits: dict) -> np.ndarray:
    """The camera and bounce visit counts side by side as a uint8 RGB image: black, red, then
    yellow, 0 to the larger of their 99th percentiles."""
    top = max(float(np.quantile(visits["camera"], 0.99)), float(np.quantile(visits["bounce"], 0.99)), 1.0)
    v = np.clip(np.concatenate([visits["camera"], visits["bounce"]], axis=1) / top, 0.0, 1.0)
    rgb = np.stack([np.clip(2 * v, 0, 1), np.clip(2 * v - 1, 0, 1), np.zeros_like(v)], axis=-1)
    return (rgb * 255 + 0.5).astype(np.uint8)


def measure(path: str, n_rays: int, seed: int = 1, tiles: int = 40) -> dict:
    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.pack import pack_scene

    scene = load_scene(path)
    packed = pack_scene(scene, bvh_width=4)
    tree = WideTree(packed)
    rng = np.random.default_rng(seed)
    out = {"scene": path, "triangles": int(packed.num_source_triangles or packed.num_triangles),
           "rows": int(packed.num_triangles), "wide_nodes": int(packed.bvh_nodes.shape[0]),
           "levels": int(packed.bvh_levels), "kinds": {}}
    for kind, (o, d, any_hit) in scene_rays(scene, packed, tree, n_rays, rng).items():
        runs = [traverse(tree, o[i], d[i], any_hit) for i in range(len(o))]
        nodes = np.array([r["nodes"] for r in runs], np.float64)
        # for shadow rays, to the nearest hit: what a closest-hit query must visit (an any-hit one
        # may stop sooner)
        nearest = [traverse(tree, o[i], d[i])["t"] if any_hit else r["t"] for i, r in enumerate(runs)]
        fewest = np.array([fewest_nodes(tree, o[i], d[i], t) for i, t in enumerate(nearest)], np.float64)
        out["kinds"][kind] = {
            "rays": len(runs), "hit": float(np.mean([r["row"] >= 0 for r in runs])),
            "nodes_mean": float(nodes.mean()), "nodes_p90": float(np.quantile(nodes, 0.9)),
            "nodes_max": int(nodes.max()), "fewest_nodes_mean": float(fewest.mean()),
            "warp_nodes": warp_nodes(nodes, rng),
            "leaves_mean": float(np.mean([r["leaves"] for r in runs])),
            "triangles_mean": float(np.mean([r["triangles"] for r in runs]))}
    out["bounce_warps"] = tile_bounce_warps(scene, packed, tree, tiles, rng)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--rays", type=int, default=1000, help="camera rays a scene (bounce and shadow rays from their hits)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--tiles", type=int, default=40, help="8x4 pixel tiles whose bounce rays run in lockstep")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--widths", help="comma-separated node widths (e.g. 2,4,8): the bounce-ray warps' lockstep steps "
                    "with the scene's binary tree collapsed to each (CollapsedTree), instead of the tables")
    ap.add_argument("--heatmap", type=Path, help="PNG of each pixel's camera and bounce ray node visits (first scene)")
    ap.add_argument("--heat-size", default="192x108", help="the heat map's pixels per half, WxH")
    ap.add_argument("--light-frame", action="store_true",
                    help="shadow rays to the first distant light: the renderer's tree against one built over "
                         "the scene turned so that the light lies along +z")
    args = ap.parse_args(argv)
    if args.light_frame:
        return _light_frame(args)
    if args.heatmap:
        return _heatmap(args)
    if args.widths:
        return _widths(args)
    results = []
    print("| scene | levels | ray kind | rays | wide nodes visited: mean / p90 / max | fewest possible | a warp of 32 "
          "random rays (busiest lane) | leaves | triangles |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in args.scenes:
        if not Path(path).exists():
            print(f"(skipped: {path} does not exist)")
            continue
        r = measure(path, args.rays, args.seed, args.tiles)
        results.append(r)
        for kind, k in r["kinds"].items():
            print(f"| {scene_name(path)} | {r['levels']} | {kind} "
                  f"| {k['rays']} | {k['nodes_mean']:.1f} / {k['nodes_p90']:.0f} / {k['nodes_max']} "
                  f"| {k['fewest_nodes_mean']:.1f} | {k['warp_nodes']:.1f} | {k['leaves_mean']:.2f} "
                  f"| {k['triangles_mean']:.1f} |")
    print("\n| scene | 8x4 tiles | bounce-ray warp: steps (node or leaf visits in lockstep) | lanes busy a step "
          "| distinct fetches a step |")
    print("|---|---|---|---|---|")
    for r in results:
        w = r["bounce_warps"]
        if w["tiles"]:
            print(f"| {scene_name(r['scene'])} | {w['tiles']} | {w['steps']:.1f} | {w['busy_per_step']:.1f} "
                  f"| {w['fetches_per_step']:.1f} |")
    if args.json:
        write_json(args.json, results, indent=1)
    return 0


def _widths(args) -> int:
    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.pack import pack_scene

    widths = [int(w) for w in args.widths.split(",")]
    results = []
    print("| scene | width | wide nodes | bounce-ray warp steps (8x4 tiles) | lanes busy a step | nodes a ray |")
    print("|---|---|---|---|---|---|")
    for path in args.scenes:
        if not Path(path).exists():
            print(f"(skipped: {path} does not exist)")
            continue
        scene = load_scene(path)
        packed = pack_scene(scene, bvh_width=2)
        for width in widths:
            tree = CollapsedTree(packed, width)
            w = tile_bounce_warps(scene, packed, tree, args.tiles, np.random.default_rng(args.seed))
            rays = pixel_visits(scene, packed, tree, (32, 18), np.random.default_rng(args.seed))["bounce"]
            results.append({"scene": path, "width": width, "wide_nodes": int(tree.entry.shape[0]), **w,
                            "bounce_nodes_mean": float(rays[rays > 0].mean())})
            print(f"| {scene_name(path)} | {width} | {tree.entry.shape[0]:,} | {w.get('steps', 0):.2f} "
                  f"| {w.get('busy_per_step', 0):.1f} | {results[-1]['bounce_nodes_mean']:.1f} |", flush=True)
    if args.json:
        write_json(args.json, results, indent=1)
    return 0


def light_frame(direction) -> np.ndarray:
    """A rotation (rows an orthonormal basis) taking `direction` to +z."""
    z = np.asarray(direction, np.float64) / np.linalg.norm(direction)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])


def light_frame_visits(path, n_rays: int, seed: int = 1) -> dict:
    """The shadow rays towards a scene's first distant light through the renderer's tree and
    through a tree built the same way over the scene turned so that the light lies along +z
    (its shadow rays then run along an axis of every box): nodes, leaves and triangles a ray
    visits, and whether the two agree on each ray's answer. `path`: a scene file, or a Scene."""
    import copy

    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.pack import pack_scene

    scene = load_scene(path) if isinstance(path, (str, Path)) else path
    if not scene.distant_lights:
        raise SystemExit(f"{path}: no distant light")
    world = pack_scene(scene, bvh_width=4)
    rotation = light_frame(scene.distant_lights[0].direction)
    turned = copy.deepcopy(scene)
    for mesh in turned.meshes:
        mesh.positions = mesh.positions @ rotation.T
    in_light_frame = pack_scene(turned, bvh_width=4)
    rng = np.random.default_rng(seed)
    tree = WideTree(world)
    o, d, _ = scene_rays(scene, world, tree, n_rays, rng)["shadow"]
    o_turned = (o + np.asarray(world.origin, np.float64)) @ rotation.T - np.asarray(in_light_frame.origin, np.float64)
    out, answers = {"scene": str(path) if isinstance(path, (str, Path)) else "", "rays": len(o)}, {}
    for name, t, origins, dirs in (("world", tree, o, d), ("light_frame", WideTree(in_light_frame), o_turned,
                                                                       d @ rotation.T)):
        runs = [traverse(t, origins[i], dirs[i], True) for i in range(len(origins))]
        nodes = np.array([r["nodes"] for r in runs], np.float64)
        answers[name] = np.array([r["row"] >= 0 for r in runs])
        out[name] = {"wide_nodes": int(t.entry.shape[0]), "nodes_mean": float(nodes.mean()),
                     "leaves_mean": float(np.mean([r["leaves"] for r in runs])),
                     "triangles_mean": float(np.mean([r["triangles"] for r in runs])),
                     "warp_nodes": warp_nodes(nodes, rng), "blocked": float(answers[name].mean())}
    out["answers_differ"] = int((answers["world"] != answers["light_frame"]).sum())
    return out


def _light_frame(args) -> int:
    results = []
    print("| scene | tree | shadow rays | blocked | wide nodes visited | leaves | triangles | warp of 32 random rays |")
    print("|---|---|---|---|---|---|---|---|")
    for path in args.scenes:
        r = light_frame_visits(path, args.rays, args.seed)
        results.append(r)
        for name in ("world", "light_frame"):
            k = r[name]
            print(f"| {scene_name(path)} | {name} | {r['rays']} | {k['blocked']:.3f} | {k['nodes_mean']:.2f} "
                  f"| {k['leaves_mean']:.2f} | {k['triangles_mean']:.2f} | {k['warp_nodes']:.1f} |")
        print(f"(answers that differ: {r['answers_differ']})")
    if args.json:
        write_json(args.json, results, indent=1)
    return 0


def _heatmap(args) -> int:
    from lift_gl.cli import _size
    from lift_gl.image_io import write_srgb8
    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.pack import pack_scene

    path = args.scenes[0]
    scene = load_scene(path)
    packed = pack_scene(scene, bvh_width=4)
    visits = pixel_visits(scene, packed, WideTree(packed), _size(args.heat_size), np.random.default_rng(args.seed))
    write_srgb8(args.heatmap, heat_image(visits))
    for kind in ("camera", "bounce"):
        v = visits[kind]
        print(f"{scene_name(path)} {kind} rays: nodes visited mean {v.mean():.1f}, p99 {np.quantile(v, 0.99):.0f}, "
              f"max {v.max()}")
    print(f"wrote {args.heatmap} (camera rays left, bounce rays right)\n")
    print("| material | share of bounce rays' leaf visits | among the slowest 2% |\n|---|---|---|")
    for name, (every, slow) in visits["materials"].items():
        print(f"| {name} | {every:.3f} | {slow:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
