"""`lift-gl lab`: lab kits (labs/NAME/, docs/labs.md): check one, build the students' archive
without the solutions, render the reference images and their expected noise.

    lift-gl lab check labs/lab2-path-tracing
    lift-gl lab build labs/lab2-path-tracing --out dist/
    lift-gl lab references labs/lab2-path-tracing

A kit is a folder with `lab.toml` (name, title; [grade]: the settings `lift-gl grade --lab`
reads; [student]: what the archive holds; [references]: what `lab references` renders),
`handout.md`, `starter/PLUGIN/`, `solution/PLUGIN/`, and optionally `scenes/` and
`references/`. Grading is `lift-gl grade SUBMISSIONS --lab LAB --out DIR` (lift_gl/grade).
"""
from __future__ import annotations

import json
import shutil
import tomllib
import zipfile
from dataclasses import dataclass
from pathlib import Path

from .errors import LiftError, read_utf8

LAB_FILE = "lab.toml"
SOLUTION_DIR = "solution"
STARTER_DIR = "starter"
BUILD_MARKER = ".lift-gl-lab-build"   # written into a built archive folder: a rebuild may replace it
SKIPPED_NAMES = {"__pycache__", ".pytest_cache", ".DS_Store", BUILD_MARKER}
ZIP_DATE = (2020, 1, 1, 0, 0, 0)      # one timestamp for every entry: the same kit zips to the same bytes
KIND_NAMES = {str: "a string", int: "a whole number", list: "a list"}


@dataclass(frozen=True)
class ReferenceSettings:
    scenes: tuple[str, ...]   # scene files relative to the lab, or the grader's built-in names
    size: tuple[int, int]
    spp: int                  # samples per pixel of the reference image
    handout_spp: int          # the handout's renders: the noisy example and its expected error
    seed: int = 1


@dataclass(frozen=True)
class Lab:
    folder: Path
    name: str
    title: str
    reference: str            # [grade] reference: a plugin folder relative to the lab, or a built-in name
    include: tuple[str, ...]  # [student] include
    references: ReferenceSettings | None

    @property
    def path(self) -> Path:
        return self.folder / LAB_FILE

    def reference_plugin(self) -> str:
        """The reference as Renderer(integrator=...) takes it: a folder path, or a plugin name."""
        folder = self.folder / self.reference
        return str(folder) if (folder / "plugin.toml").is_file() else self.reference

    def line(self, table: str | None, key: str) -> int | None:
        from .scene.toml_loader import SourceMap

        return SourceMap(read_utf8(self.path)).line((table,) if table else (), key=key)


# ---- reading lab.toml ----
def load_lab(folder) -> Lab:
    folder = Path(folder)
    path = folder / LAB_FILE
    if not path.is_file():
        raise LiftError(f"no {LAB_FILE} here: a lab kit's folder has one (docs/labs.md)", folder)
    text = read_utf8(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise LiftError(f"not valid TOML: {exc}", path) from None
    from .scene.toml_loader import SourceMap

    lines = SourceMap(text)

    def fail(message, table=None, key=None):
        raise LiftError(message, path, lines.line((table,) if table else (), key=key))

    def get(table: dict, key: str, kind, where: str | None, default=None):
        if key not in table:
            if default is None:
                fail(f"{'[' + where + '] ' if where else ''}needs {key}", where)
            return default
        value = table[key]
        if kind is int and isinstance(value, bool) or not isinstance(value, kind):
            fail(f"{key} must be {KIND_NAMES[kind]}, not {value!r}", where, key)
        return value

    for table in ("grade", "student", "references"):
        if table in data and not isinstance(data[table], dict):
            fail(f"{table} must be a table ([{table}])", None, table)
    grade = data.get("grade", {})
    student = data.get("student", {})
    include = get(student, "include", list, "student")
    if not include or not all(isinstance(item, str) and item for item in include):
        fail("include must be a list of paths relative to the lab", "student", "include")
    references = None
    if "references" in data:
        table = data["references"]
        scenes = get(table, "scenes", list, "references")
        size = get(table, "size", list, "references")
        if not scenes or not all(isinstance(s, str) for s in scenes):
            fail("scenes must be a list of scene files (relative to the lab) or built-in names", "references", "scenes")
        if len(size) != 2 or not all(isinstance(v, int) and v > 0 for v in size):
            fail(f"size must be [width, height], not {size!r}", "references", "size")
        counts = {key: get(table, key, int, "references") for key in ("spp", "handout_spp")}
        seed = get(table, "seed", int, "references", default=1)
        for key, value in counts.items():
            if value < 1:
                fail(f"{key} must be at least 1, not {value}", "references", key)
        references = ReferenceSettings(tuple(scenes), tuple(size), counts["spp"], counts["handout_spp"], seed)
    return Lab(folder=folder, name=get(data, "name", str, None), title=get(data, "title", str, None),
               reference=get(grade, "reference", str, "grade"), include=tuple(include), references=references)


# ---- what goes to the students ----
def _files_under(path: Path) -> list[Path]:
    if path.is_file():
        return [path]
    return sorted(p for p in path.rglob("*") if p.is_file() and not SKIPPED_NAMES & set(p.parts)
                  and p.suffix != ".pyc")


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _normalised(data: bytes) -> bytes:
    """The text with line endings and trailing blanks evened out, so that a solution file saved
    again by an editor still counts as the same file."""
    return b"\n".join(line.rstrip() for line in data.replace(b"\r\n", b"\n").splitlines()).strip()


def secret_files(lab: Lab) -> dict[bytes, Path]:
    """The solution's files that the starter does not hand out as they are, by their
    normalised contents. (A file the two share, such as unchanged support code, is no secret.)"""
    given = {_normalised(p.read_bytes()) for p in _files_under(lab.folder / STARTER_DIR)} \
        if (lab.folder / STARTER_DIR).is_dir() else set()
    solution = lab.folder / SOLUTION_DIR
    secrets = {}
    for file in _files_under(solution) if solution.is_dir() else []:
        content = _normalised(file.read_bytes())
        if content and content not in given:
            secrets[content] = file
    return secrets


def student_files(lab: Lab) -> list[tuple[Path, Path]]:
    """(file, path in the archive) for everything [student] include names; refuses any path
    that is, holds or leads into the solution, and any file whose contents are a solution
    file's."""
    root = lab.folder.resolve()
    solution = (lab.folder / SOLUTION_DIR).resolve()
    secrets = secret_files(lab)
    chosen: dict[Path, Path] = {}
    where = lab.line("student", "include")  # every refusal points at the include list
    for item in lab.include:
        path = (lab.folder / item).resolve()
        if not _inside(path, root):
            raise LiftError(f"include {item!r} is outside the lab's folder", lab.path, where)
        if _inside(path, solution) or _inside(solution, path):
            raise LiftError(f"include {item!r} would put the solution ({SOLUTION_DIR}/) in the students' archive",
                            lab.path, where)
        if not path.exists():
            raise LiftError(f"include {item!r}: no such file or folder in the lab", lab.path, where)
        for file in _files_under(path):
            relative = file.relative_to(root)
            real = file.resolve()  # a link into the solution is the solution
            if _inside(real, solution):
                raise LiftError(f"{relative} leads into {SOLUTION_DIR}/ (a link): not for students", lab.path, where)
            leaked = secrets.get(_normalised(real.read_bytes()))
            if leaked is not None:
                raise LiftError(f"{relative} has the contents of the solution's {leaked.relative_to(lab.folder)}: "
                                "not for students", lab.path, where)
            chosen[relative] = file
    return [(file, relative) for relative, file in sorted(chosen.items())]


def build_archive(lab: Lab, out_dir) -> tuple[Path, Path, list[tuple[Path, int]]]:
    """Writes OUT/NAME/ and OUT/NAME.zip (entries under NAME/); returns both and the files with
    their sizes. A folder OUT/NAME that an earlier build did not make is left alone (error)."""
    files = student_files(lab)  # every check first: nothing is written for a leaking kit
    out_dir = Path(out_dir)
    folder = out_dir / lab.name
    if folder.exists():
        if not (folder / BUILD_MARKER).is_file():
            raise LiftError(f"{folder} exists and is not a folder that lab build made: remove it or choose another --out")
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    (folder / BUILD_MARKER).write_text(f"built by lift-gl lab build from {lab.folder}\n")
    listing = []
    zip_path = out_dir / f"{lab.name}.zip"
    with zipfile.ZipFile(zip_path, "w", zipfile.ZIP_DEFLATED) as archive:
        for file, relative in files:
            target = folder / relative
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(file, target)
            entry = zipfile.ZipInfo(f"{lab.name}/{relative.as_posix()}", ZIP_DATE)
            entry.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(entry, file.read_bytes())
            listing.append((relative, file.stat().st_size))
    return folder, zip_path, listing


# ---- checking a kit ----
def plugin_folders(folder: Path) -> list[Path]:
    return sorted(p.parent for p in folder.glob("*/plugin.toml")) if folder.is_dir() else []


def scene_path(lab: Lab, entry: str) -> Path:
    """A scene of the lab: a file relative to the lab, or one of the grader's built-in names."""
    from .grade.scenes import resolve_scene

    return resolve_scene(entry, lab.folder).path


def check_lab(lab: Lab) -> list[str]:
    """Everything that can be checked without rendering; raises on the first problem, else
    returns what was checked, one line each."""
    from .grade import GradeSettings
    from .plugins import find_plugin, load_manifest
    from .scene.loader import load_scene

    done = []
    settings = GradeSettings.from_lab(lab.folder)
    done.append(f"[grade]: reference {lab.reference}, {len(settings.scenes)} scenes at "
                f"{settings.size[0]}x{settings.size[1]}, {settings.seeds} seeds of {settings.spp} spp")
    find_plugin(lab.reference_plugin())  # the solution's folder, or a built-in plugin's name
    starters, solutions = plugin_folders(lab.folder / STARTER_DIR), plugin_folders(lab.folder / SOLUTION_DIR)
    if not starters:
        raise LiftError(f"no plugin in {STARTER_DIR}/ (a folder with plugin.toml)", lab.folder)
    for folder in starters + solutions:
        load_manifest(folder)
    missing = sorted({p.name for p in starters} - {p.name for p in solutions})
    if missing:
        raise LiftError(f"starter plugins without a solution in {SOLUTION_DIR}/: {', '.join(missing)}", lab.folder)
    done.append(f"plugins: {', '.join(str(p.relative_to(lab.folder)) for p in starters + solutions)}")
    entries = list(settings.scenes) + list(lab.references.scenes if lab.references else [])
    for entry in dict.fromkeys(entries):
        load_scene(scene_path(lab, entry))
    done.append(f"scenes load: {', '.join(dict.fromkeys(entries))}")
    done.append(f"students' archive: {len(student_files(lab))} files, no solution among them")
    return done


# ---- reference images ----
def reference_stem(entry: str) -> str:
    return Path(entry).stem


def render_references(lab: Lab, scenes=None, spp=None, handout_spp=None, size=None, report=print) -> list[Path]:
    """For each scene: references/STEM.png and STEM.exr (linear, half float) at the reference's
    spp, STEM.noisy.png at the handout's spp, and STEM.json with both renders' estimated
    relative standard error (lift_gl/error_estimate.py) and what made them."""
    from .atomic import write_text
    from .image_io import write_image
    from .renderer import Renderer
    from .scene.loader import load_scene

    settings = lab.references
    if settings is None:
        raise LiftError("lab.toml has no [references] table (scenes, size, spp, handout_spp)", lab.path)
    scenes = tuple(scenes) if scenes else settings.scenes
    spp, handout_spp = spp or settings.spp, handout_spp or settings.handout_spp
    size = tuple(size) if size else settings.size
    out = lab.folder / "references"
    out.mkdir(exist_ok=True)
    integrator = lab.reference_plugin()
    written = []
    for entry in scenes:
        path = scene_path(lab, entry)
        scene = load_scene(path)
        stem = reference_stem(entry)
        runs = {}
        # Two independent seeds: the noisy example is not the first samples of the reference.
        for label, count, seed in (("reference", spp, settings.seed), ("handout", handout_spp, settings.seed + 1)):
            renderer = Renderer(scene, size=size, integrator=integrator, seed=seed)
            try:
                image = renderer.render(spp=count)
                error = renderer.estimate_error()
                runs[label] = {"spp": renderer.stats.spp, "seed": seed,
                               "seconds": round(renderer.stats.render_seconds, 2),
                               "estimated_rel_std_error": None if error is None else round(error.rel_std_error, 5),
                               "dropped_samples": renderer.stats.dropped_samples}
            finally:
                renderer.release()
            if label == "reference":
                written += [write_image(out / f"{stem}.png", image), write_image(out / f"{stem}.exr", image, half=True)]
            else:
                written.append(write_image(out / f"{stem}.noisy.png", image))
        record = {"scene": entry, "integrator": lab.reference, "size": list(size),
                  "reference": dict(runs["reference"], image=f"{stem}.exr", preview=f"{stem}.png"),
                  "handout": dict(runs["handout"], example=f"{stem}.noisy.png")}
        json_path = out / f"{stem}.json"
        write_text(json_path, json.dumps(record, indent=1) + "\n")
        written.append(json_path)
        report(f"{entry}: reference {spp} spp (est. rel. std. error {_percent(runs['reference'])}), "
               f"at the handout's {handout_spp} spp {_percent(runs['handout'])}; {runs['reference']['seconds']:.0f} s")
    return written


def _percent(run: dict) -> str:
    value = run["estimated_rel_std_error"]
    return "unknown" if value is None else f"{100 * value:.2f}%"


# ---- the command line ----
def add_parser(subparsers) -> None:
    from .arg_types import positive_int
    from .cli import _size

    p = subparsers.add_parser("lab", help="lab kits: check one, build the students' archive, render references",
                              description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="lab_command", required=True)
    check = sub.add_parser("check", help="read lab.toml, load its plugins and scenes, check the archive's contents")
    check.add_argument("lab", type=Path)
    check.set_defaults(func=cmd_check)
    build = sub.add_parser("build", help="the students' archive (a folder and a .zip) without the solutions")
    build.add_argument("lab", type=Path)
    build.add_argument("--out", type=Path, required=True, help="folder for NAME/ and NAME.zip")
    build.set_defaults(func=cmd_build)
    refs = sub.add_parser("references", help="(re)render references/: images, noisy examples, expected noise")
    refs.add_argument("lab", type=Path)
    refs.add_argument("--scenes", help="comma-separated subset of [references] scenes (default: all)")
    refs.add_argument("--spp", type=positive_int, help="samples per pixel of the references (default: lab.toml's)")
    refs.add_argument("--handout-spp", type=positive_int, help="samples per pixel of the noisy examples (default: lab.toml's)")
    refs.add_argument("--size", type=_size, help="WxH (default: lab.toml's)")
    refs.set_defaults(func=cmd_references)


def cmd_check(args) -> int:
    lab = load_lab(args.lab)
    for line in check_lab(lab):
        print(f"ok  {line}")
    print(f"{lab.name}: {lab.title}: ready")
    return 0


def cmd_build(args) -> int:
    lab = load_lab(args.lab)
    folder, zip_path, listing = build_archive(lab, args.out)
    for relative, size in listing:
        print(f"  {relative.as_posix():60s} {size:>9,d} bytes")
    print(f"{len(listing)} files (no solution among them): {folder}/ and {zip_path}")
    return 0


def cmd_references(args) -> int:
    for value, name in ((args.spp, "--spp"), (args.handout_spp, "--handout-spp")):
        if value is not None and value < 1:
            raise LiftError(f"{name} must be at least 1, not {value}")
    lab = load_lab(args.lab)
    scenes = [s.strip() for s in args.scenes.split(",")] if args.scenes else None
    written = render_references(lab, scenes, args.spp, args.handout_spp, args.size)
    print(f"wrote {len(written)} files in {lab.folder / 'references'}")
    return 0
