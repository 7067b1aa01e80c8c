"""`lift-gl new-plugin NAME`: a new plugin folder, copied from `template` (or `pt`, or any
other plugin), renamed, with a test file that checks it against independent answers.

    lift-gl new-plugin mine                      -> plugins/mine/ (under the current folder)
    lift-gl new-plugin mine --from pt --dir ~/labs
"""
from __future__ import annotations

import re
import shutil
from pathlib import Path

from .errors import LiftError
from .plugins import _IDENT, discover, find_plugin, search_path

HINT_SIZE = "128x128"  # the render new-plugin suggests (--size)

TEST_TEMPLATE = '''"""Tests of the {name} plugin, written by `lift-gl new-plugin` (started from {source}).

    python -m pytest {folder}

They hold for any unbiased light-transport integrator:
  - it renders the Cornell box, and never returns NaN or Inf;
  - white furnace: a diffuse sphere of albedo 0.8 under a sky of radiance 1 shows exactly 0.8
    (light that leaves a convex object never comes back to it, whatever the path length);
  - it converges to the image pt converges to (independent renders; a t test per 8x8 block);
  - once you keep an image as golden, it stays the same (a screenshot regression test).
An integrator that computes something else (ambient occlusion, a Whitted-style ray tracer)
fails the furnace and pt tests by design: replace them with the answers yours should give.
"""
from pathlib import Path

import numpy as np
import pytest

from lift_gl.renderer import Renderer
from lift_gl.testing import (assert_image_close, assert_mean_is, assert_same_expectation, cornell_scene,
                             furnace_scene, render_seeds)

PLUGIN = str(Path(__file__).resolve().parent)  # this folder: found wherever it is moved
SIZE = (32, 32)


def test_renders_the_cornell_box():
    renderer = Renderer(cornell_scene(), size=SIZE, integrator=PLUGIN, seed=1)
    image = renderer.render(spp=4)
    assert image.shape == (SIZE[1], SIZE[0], 3) and np.isfinite(image).all()
    assert renderer.stats.dropped_samples == 0, "radiance() returned NaN or Inf for some samples"
    assert image.mean() > 0.0, "the image is black"


def test_white_furnace():
    image = render_seeds(furnace_scene(albedo=0.8), PLUGIN, seeds=[1], spp=16, size=SIZE)[0]
    assert_mean_is(image.mean(axis=-1), 0.8)  # pixels are independent estimates of 0.8


def test_agrees_with_pt():
    scene = cornell_scene()
    # 16 renders a side: enough to estimate each block's variance (the t test's degrees of freedom)
    mine = render_seeds(scene, PLUGIN, seeds=range(1, 17), spp=8, size=SIZE)
    reference = render_seeds(scene, "pt", seeds=range(101, 117), spp=8, size=SIZE)
    assert_same_expectation(mine, reference, block=8)


def test_cornell_box_is_unchanged(golden, request):
    """Skipped until you keep a golden image: once the image is right, run
        python -m pytest {folder} --update-golden
    to write golden/cornell.exr. Afterwards a change that alters the image fails, leaving
    golden/cornell.actual.png and golden/cornell.diff.png to look at."""
    path = golden("cornell.exr")
    if not path.exists() and not request.config.getoption("--update-golden", default=False):
        pytest.skip("no golden image yet: run pytest with --update-golden once the image is right")
    image = Renderer(cornell_scene(), size=SIZE, integrator=PLUGIN, seed=1).render(spp=16)
    # The same seed on the same driver renders the same image bit for bit; the tolerance
    # only allows for float rounding. On another machine or driver, make the golden again.
    assert_image_close(image, path, relmse=1e-6)
'''


def add_parser(subparsers) -> None:
    p = subparsers.add_parser("new-plugin", help="create a plugin folder to start an integrator from",
                              description="Copy a plugin (the commented `template` by default) into a new "
                                          "folder DIR/NAME, renamed, with a test file.")
    p.add_argument("name", metavar="NAME", help="the new plugin's name (letters, digits, _)")
    p.add_argument("--from", dest="source", default="template", metavar="PLUGIN",
                   help="plugin to copy: template (a commented starting point, default), pt (the "
                        "reference path tracer), or any other that `lift-gl plugins` lists")
    p.add_argument("--dir", default="plugins", metavar="DIR",
                   help="folder to create NAME in (default: ./plugins)")
    p.add_argument("--plugins", action="append", default=[], metavar="DIR", help="more folders to copy from")
    p.set_defaults(func=cmd_new_plugin)


def cmd_new_plugin(args) -> int:
    folder = create_plugin(args.name, args.source, Path(args.dir), args.plugins)
    entry = find_plugin(str(folder)).entry
    on_path = any(_same(folder.parent, d) for d in search_path(args.plugins))
    found_as = args.name if on_path else str(folder)
    files = [("plugin.toml", "the manifest: name, entry file, parameters"),
             (entry, "your radiance(): start where it says YOUR TURN"),
             (f"test_{args.name}.py", "checks it: renders, white furnace, agrees with pt, golden image")]
    width = max(len(f) for f, _ in files) + 2
    print(f"created {_shown(folder)}/ from {args.source}:")
    for file, what in files:
        print(f"  {file:<{width}}{what}")
    print("next:")
    from .testing import CORNELL  # numpy: only for this command, not at every CLI start

    # a small size: the scene's film (512x512) takes minutes on a CPU rasterizer, this about 10 s
    print(f"  lift-gl render {_shown(CORNELL)} --integrator {found_as} --spp 64 --size {HINT_SIZE} "
          f"--out {args.name}.png")
    print(f"  python -m pytest {_shown(folder)}")
    if not on_path:
        print(f"  (to use it by name: --plugins {folder.parent}, or add that folder to LIFT_GL_PLUGIN_PATH)")
    return 0


def create_plugin(name: str, source: str = "template", parent: Path = Path("plugins"), plugin_dirs=()) -> Path:
    """Copy plugin `source` to parent/name, renamed; write its test file. The new folder."""
    if not _IDENT.match(name):
        raise LiftError(f"plugin name {name!r} must be an identifier (letters, digits, _; not starting with a digit)")
    existing = discover(plugin_dirs)
    if name in existing:
        raise LiftError(f"a plugin named {name!r} exists already ({existing[name].folder}); choose another name")
    original = find_plugin(source, plugin_dirs)
    folder = Path(parent) / name
    if folder.exists():
        raise LiftError(f"{folder} exists already; choose another name or --dir")
    shutil.copytree(original.folder, folder, ignore=shutil.ignore_patterns("__pycache__", "test_*.py", "*.pyc"))

    entry = name + Path(original.entry).suffix
    (folder / original.entry).rename(folder / entry)
    source_text = (folder / entry).read_text()
    (folder / entry).write_text(re.sub(rf"^// {re.escape(original.name)}:", f"// {name}:", source_text, count=1))

    manifest = folder / "plugin.toml"
    text = manifest.read_text()
    for key, value in (("name", name), ("entry", entry),
                       ("description", f"A new integrator, started from {original.name}. "
                                       "Say here what it computes: lift-gl plugins shows it.")):
        text, count = re.subn(rf'^{key}\s*=\s*".*"$', f'{key} = "{value}"', text, count=1, flags=re.M)
        if count == 0 and key != "description":
            raise LiftError(f"cannot rename the copy: no one-line {key!r} in {original.manifest}")
    manifest.write_text(text)
    (folder / f"test_{name}.py").write_text(TEST_TEMPLATE.format(name=name, source=original.name, folder=folder))
    find_plugin(str(folder))  # the copy must load, or the error is ours, not the student's
    return folder.resolve()


def _shown(path: Path) -> str:
    """A path relative to the current folder when it lies inside it, else absolute."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _same(a: Path, b: Path) -> bool:
    try:
        return Path(a).resolve() == Path(b).resolve()
    except OSError:
        return False
