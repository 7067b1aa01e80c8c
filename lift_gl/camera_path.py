"""Camera path files: keyframes that `lift-gl render --camera-path FILE --frames N` follows
to write an image sequence (docs/temporal.md).

    # a pan to the right over two seconds
    [[keyframe]]
    time = 0.0
    position = [0, 1, 6.8]
    target = [0, 1, 0]

    [[keyframe]]
    time = 2.0
    position = [0.4, 1, 6.8]
    target = [0.4, 1, 0]
    fov = 19.5                 # optional; else the scene camera's

    [[move]]                   # optional: an object that moves between frames
    object = "glass sphere"    # its name in the scene file
    velocity = [-0.5, 0, 0]    # scene units per unit of path time, from its place at time 0

Frame i of N is at time t0 + i (t1 - t0) / (N - 1) (t0, t1: first and last keyframe);
between keyframes position, target and fov are interpolated linearly. `[[move]]` translates
an object between frames (the scene is rebuilt for each frame; a moved [[instances]] entry,
named by its `name`, changes its transform only, and the renderer rebuilds just the small
top-level tree over the instances); that is not motion blur
(Mesh.velocity moves objects while the shutter is open, within one frame).
"""
from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import limits
from .errors import SceneError, read_utf8
from .scene.model import Camera, Scene
from .scene.primitives import translate_matrix
from .scene.validate import camera_problem


@dataclass(frozen=True)
class Keyframe:
    time: float
    position: np.ndarray
    target: np.ndarray
    fov: float | None = None


@dataclass(frozen=True)
class Move:
    name: str
    velocity: np.ndarray


@dataclass
class CameraPath:
    keyframes: list[Keyframe]
    moves: list[Move] = field(default_factory=list)
    path: Path | None = None

    def times(self, frames: int) -> list[float]:
        t0, t1 = self.keyframes[0].time, self.keyframes[-1].time
        if frames == 1:
            return [t0]
        return [t0 + (t1 - t0) * i / (frames - 1) for i in range(frames)]

    def camera_at(self, time: float, base: Camera) -> Camera:
        """The scene camera `base` moved to the path's place at `time` (clamped to the path)."""
        keys = self.keyframes
        times = [k.time for k in keys]
        i = int(np.clip(np.searchsorted(times, time, side="right") - 1, 0, len(keys) - 1))
        a, b = keys[i], keys[min(i + 1, len(keys) - 1)]
        s = 0.0 if b.time == a.time else float(np.clip((time - a.time) / (b.time - a.time), 0.0, 1.0))
        fov_a = a.fov if a.fov is not None else base.fov_deg
        fov_b = b.fov if b.fov is not None else base.fov_deg
        camera = dataclasses.replace(base, position=(1 - s) * a.position + s * b.position,
                                     target=(1 - s) * a.target + s * b.target, fov_deg=(1 - s) * fov_a + s * fov_b)
        problem = camera_problem(camera.position, camera.target, camera.up, camera.fov_deg)
        if problem:  # between two good keyframes (position and target crossing): the scene's rule
            raise SceneError(f"at time {time:g}: {problem}", self.path)
        return camera

    def scene_at(self, time: float, scene: Scene) -> Scene:
        """The scene with its `[[move]]` objects translated by velocity * time (and the path's camera)."""
        camera = self.camera_at(time, scene.camera)
        if not self.moves:
            return dataclasses.replace(scene, camera=camera)
        velocity = {m.name: m.velocity for m in self.moves}
        meshes = [dataclasses.replace(m, positions=m.positions + time * velocity[m.name]) if m.name in velocity else m
                  for m in scene.meshes]
        spheres = [dataclasses.replace(s, center=s.center + time * velocity[_name(s)]) if _name(s) in velocity else s
                   for s in scene.spheres]
        # an instance moves by its transform alone: its mesh's BVH stays as it is
        instances = [dataclasses.replace(i, transform=translate_matrix(time * velocity[i.name]) @ i.transform)
                     if i.name in velocity else i for i in scene.instances]
        return dataclasses.replace(scene, camera=camera, meshes=meshes, spheres=spheres, instances=instances)

    def check_objects(self, scene: Scene) -> None:
        """Each [[move]] names an object of `scene`, and each keyframe's camera (with the scene
        camera's up and fov where the keyframe has none) is one the scene loader accepts."""
        for i, k in enumerate(self.keyframes):
            problem = camera_problem(k.position, k.target, scene.camera.up, k.fov if k.fov is not None else scene.camera.fov_deg)
            if problem:
                raise SceneError(f"keyframe {i + 1} (time {k.time:g}): {problem}", self.path)
        names = {m.name for m in scene.meshes} | {_name(s) for s in scene.spheres} | {i.name for i in scene.instances}
        for move in self.moves:
            if move.name not in names:
                raise SceneError(f"[[move]] names object {move.name!r}, which the scene has not "
                                 f"(it has: {', '.join(sorted(n for n in names if n)) or 'no named objects'})",
                                 self.path)


def _name(sphere) -> str:
    return (sphere.authored or {}).get("name", "")


def _finite_number(value) -> float | None:
    """A TOML number as a finite float (None: not one). TOML integers have no size limit, and
    numpy cannot test one past int64 (isfinite raised TypeError); true and false are not numbers."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if np.isfinite(number) else None


def _vec3(value, what: str, path) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be 3 numbers, not {value!r}", path) from None
    if not np.all(np.isfinite(v)):
        raise SceneError(f"{what} must be finite, not {value!r}", path)
    return v


def load_camera_path(path) -> CameraPath:
    """Read a camera path file; a bad one raises SceneError naming the file."""
    path = Path(path)
    try:
        limits.check_settings_file(path)
        data = tomllib.loads(read_utf8(path, SceneError))
    except (FileNotFoundError, IsADirectoryError):
        raise SceneError("camera path file not found", path) from None
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise SceneError(f"not a valid TOML camera path: {exc}", path) from None
    unknown = set(data) - {"keyframe", "move"}
    if unknown:
        raise SceneError(f"unknown table(s) {', '.join(sorted(unknown))}: a camera path has [[keyframe]] "
                         "and [[move]] tables", path)
    for table in ("keyframe", "move"):
        if not (isinstance(data.get(table, []), list) and all(isinstance(t, dict) for t in data.get(table, []))):
            raise SceneError(f"'{table}' must be an array of tables ([[{table}]]), not {data[table]!r}", path)
    keyframes = []
    for i, k in enumerate(data.get("keyframe", [])):
        where = f"keyframe {i + 1}"
        missing = {"time", "position", "target"} - set(k)
        if missing:
            raise SceneError(f"{where} lacks {', '.join(sorted(missing))}", path)
        time = _finite_number(k["time"])
        if time is None:
            raise SceneError(f"{where}: time must be a finite number, not {k['time']!r}", path)
        fov = k.get("fov")
        if fov is not None and not (isinstance(fov, (int, float)) and 0 < fov < 180):
            raise SceneError(f"{where}: fov must be in (0, 180) degrees, not {fov!r}", path)
        position, target = _vec3(k["position"], f"{where} position", path), _vec3(k["target"], f"{where} target", path)
        if np.array_equal(position, target):
            raise SceneError(f"{where}: position and target are the same point", path)
        keyframes.append(Keyframe(time, position, target, None if fov is None else float(fov)))
    if not keyframes:
        raise SceneError("a camera path needs at least one [[keyframe]] (time, position, target)", path)
    if any(b.time <= a.time for a, b in zip(keyframes, keyframes[1:])):
        raise SceneError("keyframe times must increase", path)
    moves = []
    for i, m in enumerate(data.get("move", [])):
        if not isinstance(m.get("object"), str):
            raise SceneError(f"move {i + 1}: object must be the name of an object in the scene", path)
        moves.append(Move(m["object"], _vec3(m.get("velocity"), f"move {i + 1} velocity", path)))
    return CameraPath(keyframes, moves, path)
