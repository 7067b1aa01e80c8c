"""Fuzzing the loaders: one harness for every kind of file lift-gl reads.

A loader under fuzz is a row of TARGETS: a name, the file name the fuzzed input is written to
(its suffix picks the format), the function that loads it, the check of what it loaded, and
the hypothesis strategy of its inputs (tests/fuzz_strategies.py: valid files built from the
format's structure and then broken, and corpus seeds mutated byte by byte). An input is a
Case: the main file's bytes and the files beside it (meshes, includes, images, a plugin's
shaders, symbolic links, a FIFO, folders), written to a fresh folder for each case.

The property (check_case). Loading any input either
- succeeds, and what it loaded is sound: a scene packs into GPU arrays that are all finite,
  with non-negative colours, emission and environment texels and a camera with a finite
  basis (check_scene); a camera path gives such a camera at every frame; a plugin reads
  files only from its own folder and the GLSL library; or
- ends in exactly one LiftError that names a file, reads as one line and was not marked by
  the loader as an internal failure ('refused' when it names a line too, else 'refused,
  no line').
Anything else escapes (Escape, with its kind): any other exception, a LiftError marked
internal or naming no file, a non-finite or negative value that would reach the GPU, more
than HANG_CPU_SECONDS of CPU (or HANG_WALL_SECONDS of wall time), an attempt to hold more
than MEMORY_LIMIT_BYTES beyond what the process held before the case (the address space is
limited during each case, so the attempt fails at once with a MemoryError, which counts even
where a loader turns it into a LiftError), or text the loader printed to stdout or stderr.

Used by tests/test_fuzz_loaders.py (a derandomized sample of every row, and every case of
the corpus) and benchmarks/fuzz_loaders.py (10,000 cases a row, counted).
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import resource
import shutil
import signal
import tempfile
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from lift_gl.errors import LiftError

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "scenes"
DATA = REPO / "tests" / "data"
FUZZ_DATA = DATA / "fuzz"

HANG_CPU_SECONDS = 5.0
HANG_WALL_SECONDS = 30.0  # a case blocked without using the CPU (a FIFO, a lock)
MEMORY_LIMIT_BYTES = 1 << 30


# ---- inputs ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Link:
    """A symbolic link to `target` (absolute, or relative to the link's folder)."""
    target: str


@dataclass(frozen=True)
class Fifo:
    """A named pipe: opening it for reading blocks until someone writes."""


@dataclass(frozen=True)
class Folder:
    """A directory where a file is expected."""


Content = bytes | Link | Fifo | Folder


@dataclass
class Case:
    """One input: `main` is written to the target's file name, `files` beside it (names
    relative to its folder; '../x' lands in the folder above, still inside the fuzz root)."""
    main: Content
    files: dict[str, Content] = field(default_factory=dict)
    how: str = ""  # what was built and broken, for reports
    name: str = ""  # the main file's name, where the target's does not fit (its format)

    def describe(self) -> str:
        head = self.main[:160] if isinstance(self.main, bytes) else self.main
        return f"{self.how or 'case'}; main {head!r}; files {sorted(self.files)}"


def write_file(path: Path, content: Content) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif isinstance(content, Link):
        os.symlink(content.target, path)
    elif isinstance(content, Fifo):
        os.mkfifo(path)
    else:
        path.mkdir(exist_ok=True)


def _clear(root: Path) -> None:
    for entry in root.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()


def write_case(case: Case, root: Path, filename: str, siblings=()) -> Path:
    """Empty `root`, then write the case: its folder `root/case/` holds the siblings, the
    case's files and the main file (`case.name`, else `filename`); names starting '../'
    land in `root` itself. Returns the main file's path."""
    root.mkdir(parents=True, exist_ok=True)
    _clear(root)
    folder = root / "case"
    folder.mkdir()
    for sibling in siblings:
        try:
            os.link(sibling, folder / sibling.name)
        except OSError:
            shutil.copy(sibling, folder / sibling.name)
    for name, content in case.files.items():
        target = root / name[3:] if name.startswith("../") else folder / name
        if target.exists() or target.is_symlink():
            target.unlink()
        write_file(target, content)
    path = folder / (case.name or filename)
    if path.exists() or path.is_symlink():
        path.unlink()
    write_file(path, case.main)
    return path


def save_case(case: Case, folder: Path, target: "Target") -> Path:
    """Keep an input: its files under `folder` ('../x' as 'up-x'), what was done in HOW.txt
    and which target and main file in CASE.json (load_saved reads it back)."""
    import json

    folder.mkdir(parents=True, exist_ok=True)
    main = case.name or target.filename
    for name, content in {**case.files, main: case.main}.items():
        path = folder / name.replace("../", "up-")
        if not (path.exists() or path.is_symlink()):
            write_file(path, content)
    (folder / "HOW.txt").write_text(case.how + "\n")
    (folder / "CASE.json").write_text(json.dumps({"target": target.name, "main": main}) + "\n")
    return folder


def load_saved(folder: Path) -> tuple["Target", Case]:
    """The target and the case that save_case kept in `folder`."""
    import json

    if (folder / "CASE.json").exists():
        info = json.loads((folder / "CASE.json").read_text())
    else:  # kept before CASE.json: the target from the folder's name
        slug = folder.name.rsplit("-", 2)[0]
        target = next(t for t in TARGETS if re.sub(r"[^a-z0-9]+", "_", t.name.lower()).strip("_") == slug)
        info = {"target": target.name, "main": target.filename}
    files: dict[str, Content] = {}
    main: Content = b""
    for path in sorted(folder.iterdir()):
        if path.name in ("HOW.txt", "CASE.json"):
            continue
        content: Content = (Link(os.readlink(path)) if path.is_symlink() else Folder() if path.is_dir()
                            else Fifo() if path.is_fifo() else path.read_bytes())
        if path.name == info["main"]:
            main = content
        else:
            files["../" + path.name[3:] if path.name.startswith("up-") else path.name] = content
    how = (folder / "HOW.txt").read_text().strip() if (folder / "HOW.txt").exists() else ""
    return BY_NAME[info["target"]], Case(main, files, how, name=info["main"])


# ---- the property ---------------------------------------------------------------------------

class Escape(Exception):
    """An input the loader did not handle: `kind` is exception, internal, unclear, value,
    hang, memory, printed or outside (a file read from outside where it may come from)."""

    KINDS = ("exception", "internal", "unclear", "value", "hang", "memory", "printed", "outside")

    def __init__(self, kind: str, message: str):
        self.kind, self.message = kind, " ".join(str(message).split())[:400]
        super().__init__(f"{kind}: {self.message}")


class CaseTimeout(BaseException):
    """Raised by the timers inside a loader (a BaseException, so that no `except
    Exception` in a loader can swallow it)."""


def _virtual_bytes() -> int | None:
    try:
        return int(Path("/proc/self/statm").read_text().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


@contextlib.contextmanager
def limits():
    """Time and memory limits for one case, where the platform has them (Linux, main
    thread): CPU and wall-clock timers that raise CaseTimeout, and the address space
    limited to MEMORY_LIMIT_BYTES above its current size."""
    main = threading.current_thread() is threading.main_thread()

    def timeout(signum, frame):
        raise CaseTimeout("CPU" if signum == signal.SIGPROF else "wall clock")

    old_handlers = {}
    if main:
        for sig, which, seconds in ((signal.SIGPROF, signal.ITIMER_PROF, HANG_CPU_SECONDS),
                                    (signal.SIGALRM, signal.ITIMER_REAL, HANG_WALL_SECONDS)):
            old_handlers[sig] = signal.signal(sig, timeout)
            signal.setitimer(which, seconds, 1.0)  # again each second, should one be swallowed
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    vm = _virtual_bytes()
    limited = vm is not None
    if limited:
        cap = vm + MEMORY_LIMIT_BYTES
        if hard != resource.RLIM_INFINITY:
            cap = min(cap, hard)
        resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        if limited:
            resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
        if main:
            signal.setitimer(signal.ITIMER_PROF, 0)
            signal.setitimer(signal.ITIMER_REAL, 0)
            for sig, handler in old_handlers.items():
                signal.signal(sig, handler)


def _flush_c_streams() -> None:
    import ctypes
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):
        pass


@contextlib.contextmanager
def captured_output():
    """What the loader prints: to sys.stdout and sys.stderr, and to file descriptors 1 and 2
    (C libraries write there past Python's streams); a list that holds the text once the
    block ends."""
    printed: list[str] = []
    import sys
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    _flush_c_streams()
    python_text = io.StringIO()  # Python-level prints (pybind11's py::print writes to sys.stdout)
    with tempfile.TemporaryFile() as sink, contextlib.redirect_stdout(python_text), \
            contextlib.redirect_stderr(python_text):
        saved = [os.dup(1), os.dup(2)]
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield printed
        finally:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            _flush_c_streams()  # what C and C++ libraries buffered (OpenEXR's warnings)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            sink.seek(0)
            printed.append(sink.read().decode("utf-8", "replace") + python_text.getvalue())


def _chain(exc: BaseException):
    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        yield exc
        exc = exc.__cause__ or exc.__context__


@dataclass
class Outcome:
    kind: str  # 'loaded', 'refused' or 'refused, no line'
    message: str = ""
    warned: bool = False  # a SceneWarning (or a plugin's warning) was issued
    first_warning: str = ""
    numpy_warnings: int = 0  # RuntimeWarnings (overflow, invalid value) that reached the user
    seconds: float = 0.0


_WARM = False


def warm_up() -> None:
    """Import what the loaders import lazily (trimesh and its exchange modules, pillow's
    plugins, OpenEXR), by loading one small file of each kind, outside any case: imports
    take seconds of CPU, which the first case to need them would be charged as a hang."""
    global _WARM
    if _WARM:
        return
    _WARM = True
    import base64
    import json

    import OpenEXR  # noqa: F401
    from PIL import Image

    from lift_gl.scene.loader import load_scene
    from lift_gl.scene.pack import pack_scene

    import lift_gl.camera_path  # noqa: F401
    import lift_gl.passes.pixel_filter  # noqa: F401
    import lift_gl.passes.trace  # noqa: F401
    import lift_gl.report.reference  # noqa: F401

    Image.init()
    camera_path_scene()
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        folder = Path(tmp)
        positions = np.array([[-1, 0, -1], [1, 0, -1], [0, 0, 1]], "<f4").tobytes()
        doc = {"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
               "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
               "bufferViews": [{"buffer": 0, "byteLength": 36}],
               "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,"
                            + base64.b64encode(positions).decode()}]}
        (folder / "warm.gltf").write_text(json.dumps(doc))
        (folder / "warm.obj").write_text("v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n")
        shutil.copy(FUZZ_DATA / "tri.ply", folder / "warm.ply")
        for name in ("warm.gltf", "warm.obj", "warm.ply", "path_scene.toml", "small.xml", "rich.pbrt"):
            source = folder / name if (folder / name).exists() else FUZZ_DATA / name
            pack_scene(load_scene(source), cache_dir=folder / "bvh-cache")


def check_case(target: "Target", case: Case, root: Path) -> Outcome:
    """Run the property on one input; returns its outcome or raises Escape."""
    warm_up()
    path = write_case(case, root, target.filename, target.siblings)
    start = time.process_time()
    printed: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with captured_output() as printed, limits():
                result = target.load(path)
                target.check(result, path)
            outcome = Outcome("loaded")
        except Escape:
            raise
        except CaseTimeout as exc:
            raise Escape("hang", f"more than {HANG_CPU_SECONDS:g} s of CPU or {HANG_WALL_SECONDS:g} s "
                                 f"({exc} timer)") from None
        except LiftError as exc:
            message = str(exc)
            if any(isinstance(e, MemoryError) for e in _chain(exc)):
                raise Escape("memory", f"tried to hold more than {MEMORY_LIMIT_BYTES >> 20} MiB "
                                       f"(then: {message})") from None
            if exc.internal:
                raise Escape("internal", message) from None
            if not exc.path:
                raise Escape("unclear", f"the error names no file: {message}") from None
            if "\n" in message:
                raise Escape("unclear", f"not one line: {message!r}") from None
            outcome = Outcome("refused" if exc.line is not None else "refused, no line", message)
        except MemoryError as exc:
            raise Escape("memory", f"MemoryError {exc}") from None
        except Exception as exc:  # noqa: BLE001 - this is what the fuzzer looks for
            raise Escape("exception", f"{type(exc).__name__}: {exc}") from exc
    outcome.seconds = time.process_time() - start
    text = "".join(printed).strip()
    if text:
        raise Escape("printed", f"the loader printed {text[:200]!r}")
    for w in caught:
        if issubclass(w.category, RuntimeWarning):
            outcome.numpy_warnings += 1
        elif issubclass(w.category, UserWarning):
            outcome.first_warning = outcome.first_warning or str(w.message)
            outcome.warned = True
    return outcome


# ---- checks of what loaded ------------------------------------------------------------------

def _finite(name: str, values, nonnegative: bool = False) -> None:
    a = np.asarray(values, dtype=np.float64)
    if not np.isfinite(a).all():
        raise Escape("value", f"non-finite {name}")
    if nonnegative and (a < 0).any():
        raise Escape("value", f"negative {name} (min {a.min():g})")


def check_camera(camera, name: str = "camera") -> None:
    for part in ("position", "target", "up"):
        _finite(f"{name} {part}", getattr(camera, part))
    with np.errstate(all="ignore"):
        basis = camera.basis()
    _finite(f"{name} basis (right, up, forward)", np.asarray(basis, dtype=np.float32))
    if not 0 < float(camera.fov_deg) < 180:
        raise Escape("value", f"{name} field of view {camera.fov_deg}")


def check_scene(scene, path: Path) -> None:
    """A loaded scene is sound: everything that reaches the GPU is finite, colours and
    emission are not negative, and the camera and film are usable."""
    from lift_gl.passes.pixel_filter import filter_uniforms
    from lift_gl.scene.pack import pack_scene

    packed = pack_scene(scene, cache_dir=path.parent / "bvh-cache")
    for name in ("tri_pos", "tri_normal", "tri_uv", "bounds"):
        _finite(name, getattr(packed, name))
    _finite("material colours and emission", packed.materials[:, :2, :3], nonnegative=True)
    _finite("materials", packed.materials)
    _finite("spheres", packed.spheres[:, 0])
    _finite("light table", packed.lights[:, 1:], nonnegative=True)
    if packed.motion is not None:
        _finite("motion", packed.motion)
    for name, value in packed.uniforms.items():
        if isinstance(value, np.ndarray) and value.dtype.kind == "f" or isinstance(value, float):
            _finite(f"uniform {name}", value)
    _finite("distant lights' irradiance", packed.uniforms["u_distant_irradiance"], nonnegative=True)
    for light in scene.distant_lights:
        _finite("distant light irradiance", light.irradiance, nonnegative=True)
        _finite("distant light direction", light.direction)
    env = scene.environment
    if env is not None:
        _finite("environment radiance", env.radiance, nonnegative=True)
        if env.image is not None:
            _finite("environment map texels", env.image, nonnegative=True)
            w, h = packed.uniforms["u_env_map_size"]
            start = packed.uniforms["u_env_map_offsets"][0]
            texels = packed.images[start:start + 4 * w * h].view(np.float32)
            _finite("packed environment texels", texels, nonnegative=True)
    for texture in scene.textures:
        if texture.pixels.ndim != 3 or 0 in texture.pixels.shape[:2]:
            raise Escape("value", f"texture {texture.name} of shape {texture.pixels.shape}")
    check_camera(packed.to_gpu_camera(scene.camera))
    uniforms = filter_uniforms(scene.pixel_filter, scene.film_size, (8, 8))
    for name, value in uniforms.items():
        if not isinstance(value, (str, bool)):
            _finite(f"pixel filter {name}", value)


# ---- the targets ----------------------------------------------------------------------------

@dataclass
class Target:
    name: str
    filename: str
    load: Callable[[Path], object]
    check: Callable[[object, Path], None]
    strategy: Callable[[], object]  # () -> a hypothesis strategy of Case
    siblings: list[Path] = field(default_factory=list)


def load_scene_file(path: Path):
    from lift_gl.scene.loader import load_scene
    return load_scene(path)


def load_plugin(path: Path):
    """The manifest, and the shader source the trace pass would compile from it."""
    from lift_gl.passes.trace import generate_main
    from lift_gl.plugins import load_manifest
    from lift_gl import shaders

    plugin = load_manifest(path.parent)
    if plugin.language != "glsl":
        return plugin, None
    return plugin, shaders.assemble(generate_main(plugin), include_dirs=[plugin.folder],
                                    main_name=f"<{plugin.name} host main>")


def check_plugin(loaded, path: Path) -> None:
    from lift_gl.shaders import SHADER_DIR

    plugin, source = loaded
    allowed = (path.parent.resolve(), SHADER_DIR.resolve())
    files = [plugin.entry_path] + (list(source.files) if source is not None else [])
    for f in files:
        if f.name.startswith("<"):
            continue
        real = Path(os.path.realpath(f))
        if not any(real == a or a in real.parents for a in allowed):
            raise Escape("outside", f"plugin reads {real}, outside its folder and the GLSL library")


def load_camera_path_file(path: Path):
    from lift_gl.camera_path import load_camera_path
    return load_camera_path(path)


_PATH_SCENE = None


def camera_path_scene():
    """The scene camera paths are checked against: named objects of every kind."""
    global _PATH_SCENE
    if _PATH_SCENE is None:
        from lift_gl.scene.loader import load_scene
        _PATH_SCENE = load_scene(FUZZ_DATA / "path_scene.toml")
    return _PATH_SCENE


def check_camera_path(camera_path, path: Path) -> None:
    import dataclasses
    from lift_gl.scene.validate import validate_scene

    scene = camera_path_scene()
    camera_path.check_objects(scene)
    for index, t in enumerate(camera_path.times(4)):
        _finite(f"frame {index} time", t)
        with np.errstate(all="ignore"):
            moved = camera_path.scene_at(t, scene)
        check_camera(moved.camera, f"frame {index} camera")
        for mesh in moved.meshes:
            _finite(f"frame {index} mesh positions", mesh.positions)
        for sphere in moved.spheres:
            _finite(f"frame {index} sphere centre", sphere.center)
        for inst in moved.instances:
            _finite(f"frame {index} instance transform", inst.transform)
        # the renderer validates what it is given, as for any scene
        validate_scene(dataclasses.replace(moved, meshes=[dataclasses.replace(m) for m in moved.meshes]))


def load_reference_image(path: Path):
    from lift_gl.report.reference import load_reference
    return load_reference(path, (8, 8))


def check_reference(reference, path: Path) -> None:
    _finite("reference pixels", reference.image)
    if reference.image.shape != (8, 8, 3):
        raise Escape("value", f"reference of shape {reference.image.shape}")


def _strategy(name: str) -> Callable[[], object]:
    """fuzz_strategies.NAME, imported when first asked for (that module imports this one)."""
    def strategy():
        import fuzz_strategies
        return getattr(fuzz_strategies, name)()
    return strategy


def _targets() -> list[Target]:
    stress_meshes = sorted((SCENES / "stress").glob("*.ply"))
    return [
        Target("TOML scene", "scene.toml", load_scene_file, check_scene, _strategy("toml_scenes"),
               siblings=stress_meshes),
        Target("pbrt scene", "scene.pbrt", load_scene_file, check_scene, _strategy("pbrt_scenes"),
               siblings=sorted(FUZZ_DATA.glob("*.pbrt")) + sorted(FUZZ_DATA.glob("*.ply"))),
        Target("Mitsuba XML scene", "scene.xml", load_scene_file, check_scene, _strategy("mitsuba_scenes")),
        Target("glTF scene", "scene.gltf", load_scene_file, check_scene, _strategy("gltf_scenes")),  # and .glb
        Target("OBJ mesh", "mesh.obj", load_scene_file, check_scene, _strategy("obj_meshes")),
        Target("PLY mesh", "mesh.ply", load_scene_file, check_scene, _strategy("ply_meshes")),
        Target("texture image", "scene.toml", load_scene_file, check_scene, _strategy("texture_cases")),
        Target("environment map", "scene.toml", load_scene_file, check_scene, _strategy("environment_cases")),
        Target("reference image", "reference.exr", load_reference_image, check_reference, _strategy("reference_cases")),
        Target("camera path", "path.toml", load_camera_path_file, check_camera_path, _strategy("camera_paths")),
        Target("plugin manifest", "plugin.toml", load_plugin, check_plugin, _strategy("plugin_manifests")),
    ]


TARGETS = _targets()
BY_NAME = {t.name: t for t in TARGETS}
