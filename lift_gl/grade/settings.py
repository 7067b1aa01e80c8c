"""What a grading run is: the reference, the scenes, and how much each submission renders.

The defaults grade a path tracer in about half a minute on a 2-core CPU (llvmpipe): 64x64
pixels, 32 independent seeds of 16 samples per pixel a scene. Many short seeds rather than a
few long ones: the seeds' spread is the test's variance, and 31 degrees of freedom give it
nearly the power of a known variance. The reference renders 4 times as many seeds of the same
spp (its variance a quarter of a submission's of equal noise, and the variance per sample of the
two comparable: a seed's variance does not fall as 1/spp where the sampler is stratified),
once, then comes from a cache.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

from ..consistency import BIAS_TOLERANCE, BLOCK_TOLERANCE
from ..errors import LiftError
from .scenes import DEFAULT_SCENES

SUBMISSION_SEED_BASE = 1          # submissions: seeds 1..K
REFERENCE_SEED_BASE = 0x51EED000  # the reference's seeds: far from any submission's, independent noise


@dataclass(frozen=True)
class GradeSettings:
    reference: str = "pt"                 # a plugin name or folder: the instructor's solution
    scenes: tuple = DEFAULT_SCENES        # built-in names (grade/scenes.py) or scene files
    size: tuple = (64, 64)                # width, height of every render
    spp: int = 16                         # samples per pixel of each seed
    seeds: int = 32                       # independent renders per submission and scene
    first_seed: int = SUBMISSION_SEED_BASE  # submissions render seeds first_seed, first_seed + 1, ...
    reference_seeds: int = 128            # the reference's seeds, of `spp` samples per pixel each
    timeout: float = 120.0                # seconds per submission and scene (compiling included)
    alpha: float = 1e-3                   # chance that a correct submission fails anywhere (all scenes)
    tolerance: float = BIAS_TOLERANCE     # relative difference of the image's mean not called a bias
    block_tolerance: float = BLOCK_TOLERANCE  # ... and of one block's (consistency.BLOCK_TOLERANCE)
    block: int = 8                        # side of the blocks tested, in pixels
    params: dict = field(default_factory=dict)  # plugin settings for every render (e.g. max_depth)
    options: tuple = ()                   # the renderer's options for every render, KEY=VALUE (lift_gl/options.py)
    jobs: int = 1                         # submissions rendered at once
    cache_dir: Path | None = None         # the reference cache (None: ~/.cache/lift-gl/grade)
    base: Path | None = None              # scenes and reference given relative to this folder (a lab)

    def __post_init__(self):
        checks = [("spp", self.spp >= 1), ("seeds", self.seeds >= 2), ("reference_seeds", self.reference_seeds >= 2),
                  ("timeout", self.timeout > 0),
                  ("alpha", 0 < self.alpha < 1), ("tolerance", 0 <= self.tolerance < 1),
                  ("block_tolerance", 0 <= self.block_tolerance < 1),
                  ("block", self.block >= 1),
                  ("jobs", self.jobs >= 1),
                  ("first_seed", 0 < self.first_seed and self.first_seed + self.seeds <= REFERENCE_SEED_BASE),
                  ("size", len(self.size) == 2 and min(self.size) >= 1)]
        for name, ok in checks:
            if not ok:
                raise LiftError(f"grade setting {name} = {getattr(self, name)!r} is out of range")
        if not self.scenes:
            raise LiftError("grade needs at least one scene")
        if not math.isfinite(self.timeout):
            raise LiftError("grade setting timeout must be finite")
        from ..options import parse_options

        parse_options(self.options)   # a bad one is one clear error here, not one per child process

    @property
    def submission_seeds(self) -> list[int]:
        return [self.first_seed + i for i in range(self.seeds)]

    @property
    def reference_seed_list(self) -> list[int]:
        return [REFERENCE_SEED_BASE + i for i in range(self.reference_seeds)]

    def reference_plugin(self) -> str:
        """The reference as find_plugin takes it: a folder relative to `base`, or a name."""
        if self.base is not None and (self.base / self.reference / "plugin.toml").is_file():
            return str(self.base / self.reference)
        return self.reference

    def as_dict(self) -> dict:
        return {f.name: (str(v) if isinstance(v, Path) else list(v) if isinstance(v, tuple) else v)
                for f in fields(self) for v in [getattr(self, f.name)]}

    def with_options(self, **changes) -> "GradeSettings":
        """A copy with the options that are not None changed."""
        return replace(self, **{k: v for k, v in changes.items() if v is not None})

    @classmethod
    def from_lab(cls, lab_dir) -> "GradeSettings":
        """The [grade] table of LAB/lab.toml; scenes and the reference relative to the lab."""
        lab_dir = Path(lab_dir)
        path = lab_dir / "lab.toml"
        if not path.is_file():
            raise LiftError("no lab.toml in this folder: a lab kit has one (docs/labs.md)", lab_dir)
        try:
            table = tomllib.loads(path.read_text(encoding="utf-8-sig")).get("grade", {})
        except tomllib.TOMLDecodeError as exc:
            raise LiftError(f"not valid TOML: {exc}", path) from None
        known = {f.name for f in fields(cls)} - {"base", "cache_dir", "jobs"}
        unknown = sorted(set(table) - known)
        if unknown:
            raise LiftError(f"[grade] has unknown keys {', '.join(unknown)} (known: {', '.join(sorted(known))})", path)
        values = dict(table)
        for key in ("scenes", "size", "options"):
            if key in values:
                values[key] = tuple(values[key])
        try:
            return cls(base=lab_dir.resolve(), **values)
        except TypeError as exc:
            raise LiftError(f"[grade]: {exc}", path) from None
