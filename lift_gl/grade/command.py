"""The `lift-gl grade` command line."""
from __future__ import annotations

from pathlib import Path

from ..errors import LiftError


def add_parser(subparsers) -> None:
    from ..arg_types import non_negative, positive, positive_int, probability, seed
    from ..cli import _size
    from .scenes import BUILTIN, DEFAULT_SCENES
    from .settings import GradeSettings

    d = GradeSettings()
    p = subparsers.add_parser(
        "grade", help="statistical verdicts on a folder of students' plugins: grades.csv, report.md",
        description="Render every plugin folder under SUBMISSIONS on each scene with independent seeds and test "
                    "its expectation against the reference's: pass (consistent, possibly noisier), biased (z: the "
                    "signed difference in standard errors), error (does not compile or crashes), timeout. "
                    "Exits 0 when grading ran, whatever the verdicts.")
    p.add_argument("submissions", type=Path, help="folder whose subfolders hold the plugins (plugin.toml)")
    p.add_argument("--lab", type=Path, help="a lab kit's folder: its lab.toml's [grade] settings (docs/labs.md); "
                                            "the options below override them")
    p.add_argument("--reference", help=f"plugin name or folder of the reference solution (default {d.reference})")
    p.add_argument("--scenes", help=f"comma-separated built-ins ({', '.join(BUILTIN)}) or scene files "
                                    f"(default {','.join(DEFAULT_SCENES)})")
    p.add_argument("--size", type=_size, help=f"WxH of every render (default {d.size[0]}x{d.size[1]})")
    p.add_argument("--spp", type=positive_int, help=f"samples per pixel of each seed (default {d.spp})")
    p.add_argument("--seeds", type=positive_int, help=f"independent renders per submission and scene (default {d.seeds})")
    p.add_argument("--first-seed", type=seed, help="the submissions' first seed (default 1: seeds 1..K)")
    p.add_argument("--reference-seeds", type=positive_int,
                   help=f"the reference's seeds, of the same spp (default {d.reference_seeds})")
    p.add_argument("--timeout", type=positive, help=f"seconds per submission and scene (default {d.timeout:g})")
    p.add_argument("--alpha", type=probability, help=f"chance that a correct submission fails (default {d.alpha:g})")
    p.add_argument("--tolerance", type=non_negative,
                   help=f"relative difference not called a bias (default {d.tolerance:g})")
    p.add_argument("--block-tolerance", type=non_negative,
                   help=f"... and for one {d.block}x{d.block} block's mean (default {d.block_tolerance:g})")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a plugin setting for every render, reference included (e.g. max_depth=8)")
    p.add_argument("--jobs", type=positive_int, help="submissions rendered at once (default 1)")
    p.add_argument("--cache-dir", type=Path, help="the reference cache (default ~/.cache/lift-gl/grade)")
    p.add_argument("--out", type=Path, required=True, help="output folder: grades.csv, report.md, pictures/")
    from ..cluster.options import add_executor_arguments
    from ..options import add_option_argument

    add_option_argument(p)
    add_executor_arguments(p)
    p.set_defaults(func=cmd_grade)


def settings_from_args(args):
    from .settings import GradeSettings

    settings = GradeSettings.from_lab(args.lab) if args.lab is not None else GradeSettings()
    params = dict(settings.params)
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise LiftError(f"--set expects NAME=VALUE, not {item!r}")
        params[key.strip()] = value.strip()
    scenes = tuple(s.strip() for s in args.scenes.split(",")) if args.scenes else None
    if scenes is not None and not all(scenes):
        raise LiftError(f"--scenes expects a comma-separated list without empty items, got {args.scenes!r}")
    return settings.with_options(reference=args.reference, scenes=scenes, size=tuple(args.size) if args.size else None,
                                 spp=args.spp, seeds=args.seeds, first_seed=args.first_seed,
                                 reference_seeds=args.reference_seeds, timeout=args.timeout, alpha=args.alpha,
                                 tolerance=args.tolerance, block_tolerance=args.block_tolerance, jobs=args.jobs,
                                 cache_dir=args.cache_dir, params=params,
                                 options=tuple(settings.options) + tuple(getattr(args, "options", ())) or None)


def cmd_grade(args) -> int:
    from ..arg_types import check_output_folder
    from .grading import VERDICTS, grade

    settings = settings_from_args(args)
    check_output_folder(args.out)
    from ..cluster.options import executor_from_args

    grades = grade(args.submissions, settings, args.out, executor=executor_from_args(args))
    counts = {v: sum(g.verdict == v for g in grades) for v in VERDICTS}
    print(", ".join(f"{n} {v}" for v, n in counts.items()) + f"; wrote {args.out / 'grades.csv'} and report.md")
    return 0
