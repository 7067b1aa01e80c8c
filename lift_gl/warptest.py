"""`lift-gl warptest`: does a sampling routine draw the density its pdf claims? (Nori's
warptest, as a command.)

    lift-gl warptest FILE.glsl --sampler NAME [--pdf NAME] --domain square|disk|sphere|hemisphere
    lift-gl warptest [FILE.glsl --sampler NAME [--pdf NAME]] --bsdf MATERIAL [--cos-theta-o C]
                     [--roughness R] [--ior N]

The sampler runs on the GPU on N uniform numbers (numpy's PCG64, --seed); its points are
counted on a grid over the domain, and each cell's count is held against N times the pdf's
integral over the cell (lift_gl/warp_kernels.py, adaptive Gauss-Legendre in a shader).
Pearson's chi-square (lift_gl/chi2.py) rejects at --alpha. Besides the histogram: a sample
outside the domain (or NaN) is a cell that expects none and rejects outright; the pdf must
integrate to 1 over the domain (a BSDF's to at most 1: what is missing is the chance that
the routine returns no sample, or a delta lobe's); a pdf negative, NaN or Inf anywhere
rejects. Exit 0: pass; 1: rejected; 2: the file does not compile, or a function is missing.
"""
from __future__ import annotations

import argparse
import json
import re
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from . import arg_types
from .atomic import write_text
from .errors import LiftError, ShaderError

DEFAULT_SAMPLES = 1 << 20
DEFAULT_ALPHA = 0.01
DEFAULT_INTEGRAL_TOLERANCE = 1e-3
# The cubature's relative accuracy, as a share of --integral-tolerance: the integral's own
# error cannot decide the check.
CUBATURE_SHARE = 0.1
FEW_CELLS = 20  # fewer cells than this after pooling: the histogram can see little
KERNEL_NAME = "<warptest kernel>"
BSDF_MATERIALS = ("diffuse", "conductor", "dielectric", "plastic")
EVERY_BSDF = {"HAS_CONDUCTOR": True, "HAS_ROUGH_CONDUCTOR": True, "HAS_DIELECTRIC": True,
              "HAS_ROUGH_DIELECTRIC": True, "HAS_PLASTIC": True, "HAS_ROUGH_PLASTIC": True}


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "warptest", help="chi-square test of a sampling routine against its pdf (exit 0 pass, 1 rejected)",
        description="Chi-square test of a sampling routine against its pdf (Nori's warptest). The sampler runs on "
        "the GPU on --samples uniform numbers; its points are counted on a grid and held against the pdf integrated "
        "over each cell. Also rejected: samples outside the domain or NaN, a pdf that does not integrate to 1 (a "
        "BSDF's: to more than 1), a pdf negative, NaN or Inf anywhere. Exit 0: pass; 1: rejected; 2: the file does "
        "not compile or lacks a function. Writes nothing unless --out DIR is given: DIR/warptest.png (observed, "
        "expected, (obs - exp) / sqrt(exp)) and DIR/warptest.json.")
    p.add_argument("file", nargs="?", metavar="FILE.glsl",
                   help="GLSL defining the sampler and its pdf (left out with --bsdf: the built-in BSDF)")
    p.add_argument("--sampler", metavar="NAME",
                   help="the sampler: vec2 NAME(vec2 u) for --domain square or disk, vec3 NAME(vec2 u) for "
                        "sphere or hemisphere; with --bsdf: bool NAME(Material m, vec3 wo, vec3 u, out BsdfSample s)")
    p.add_argument("--pdf", metavar="NAME",
                   help="its density (default: the sampler's name + '_pdf'): float NAME(vec2 p) per unit area, "
                        "float NAME(vec3 w) per unit solid angle; with --bsdf: "
                        "float NAME(Material m, vec3 wo, vec3 wi)")
    p.add_argument("--domain", choices=("square", "disk", "sphere", "hemisphere"),
                   help="[0,1]^2, the unit disk, unit directions, or directions with z >= 0")
    p.add_argument("--samples", type=arg_types.positive_int, default=DEFAULT_SAMPLES, help=f"default {DEFAULT_SAMPLES} (2^20)")
    p.add_argument("--grid", metavar="AxB", type=_grid,
                   help="cells: x by y (square, disk: over [-1,1]^2), cos theta by phi (directions); default "
                        "32x32, 32x32, 32x64, 16x64 (equal-area cells); 48x96 with --bsdf")
    p.add_argument("--alpha", type=arg_types.probability, default=DEFAULT_ALPHA,
                   help=f"significance level: the chance that a correct sampler is rejected (default {DEFAULT_ALPHA})")
    p.add_argument("--integral-tolerance", type=arg_types.positive, default=DEFAULT_INTEGRAL_TOLERANCE,
                   help=f"how far from 1 the pdf's integral may be (default {DEFAULT_INTEGRAL_TOLERANCE:g})")
    p.add_argument("--seed", type=arg_types.seed, default=0, help="seed of the uniform numbers (default 0)")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default="auto")
    p.add_argument("--out", metavar="DIR", help="write DIR/warptest.png and DIR/warptest.json")
    bsdf = p.add_argument_group("BSDF mode: directions over the whole sphere, for one outgoing direction")
    bsdf.add_argument("--bsdf", choices=BSDF_MATERIALS,
                      help="the material passed to the routine (shaders/lift/bsdf.glsl); without FILE, "
                           "the library's bsdf_sample / bsdf_pdf are tested")
    bsdf.add_argument("--cos-theta-o", type=float, default=0.5,
                      help="cosine of wo with the normal, wo = (sin, 0, cos) (default 0.5; negative: "
                           "inside a dielectric)")
    bsdf.add_argument("--roughness", type=float, default=0.3,
                      help="perceptual roughness, GGX alpha = roughness^2, as scene files take it (default 0.3; "
                           "0: smooth, a delta lobe, for plastic its diffuse part is tested)")
    bsdf.add_argument("--ior", type=float, default=1.5, help="dielectric and plastic index of refraction (default 1.5)")
    bsdf.add_argument("--color", type=_color, default=(0.8, 0.8, 0.8), metavar="R,G,B",
                      help="albedo / F0 / tint; plastic chooses its lobes by it (default 0.8,0.8,0.8)")
    bsdf.add_argument("--distribution", choices=("ggx", "beckmann"), default="ggx", help="rough conductors")
    p.set_defaults(func=cmd_warptest)


def _grid(text: str) -> tuple[int, int]:
    try:
        a, b = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--grid must be AxB, e.g. 32x32, not {text!r}") from None
    if not (1 <= a <= 1024 and 1 <= b <= 1024):
        raise argparse.ArgumentTypeError(f"--grid cells must be 1..1024 along each axis, not {text!r}")
    return a, b


def _color(text: str) -> tuple[float, float, float]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(0.0 <= v <= 1.0 for v in values):
        raise argparse.ArgumentTypeError(f"--color must be R,G,B in [0, 1], not {text!r}")
    return values


@dataclass
class WarptestResult:
    """What one check found; `reasons` is empty when it passed."""
    file: str | None
    sampler: str
    pdf: str
    domain: str
    samples: int
    seed: int
    grid: tuple[int, int]
    alpha: float
    statistic: float
    dof: int
    p_value: float            # of the histogram and every extra cell (0: a cell that expects none got samples)
    histogram_p_value: float  # of the histogram's cells alone
    pdf_integral: float
    quadrature_error: float
    integral_tolerance: float
    outside: dict             # way of missing the domain -> samples
    in_zero_pdf_cells: int    # samples in cells over which the pdf integrates to 0
    pdf_least: float
    pdf_least_at: tuple
    pdf_nonfinite: int
    bsdf: dict | None = None  # material, wo, rejected and delta counts (BSDF mode)
    reasons: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    seconds: float = 0.0
    # The pictures' data, not in the JSON.
    observed: np.ndarray | None = None
    expected: np.ndarray | None = None

    @property
    def passed(self) -> bool:
        return not self.reasons

    def to_json(self) -> dict:
        data = {k: v for k, v in asdict(self).items() if k not in ("observed", "expected")}
        data["verdict"] = "pass" if self.passed else "rejected"
        return json.loads(json.dumps(data, default=float, allow_nan=True))


# ---- the command ----------------------------------------------------------------------------
def cmd_warptest(args) -> int:
    for module in ("scipy", "matplotlib"):
        try:
            __import__(module)
        except ImportError:
            raise LiftError(f"warptest needs {module}: pip install 'lift-gl[report]'") from None
    if args.out:
        arg_types.check_output_folder(args.out)
    result = warptest(args.file, sampler=args.sampler, pdf=args.pdf, domain=args.domain, samples=args.samples,
                      grid=args.grid, alpha=args.alpha, integral_tolerance=args.integral_tolerance, seed=args.seed,
                      backend=args.backend, bsdf=args.bsdf, cos_theta_o=args.cos_theta_o, roughness=args.roughness,
                      ior=args.ior, color=args.color, distribution=args.distribution)
    print(summary(result))
    if args.out:
        from .warptest_plot import plot_warptest

        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        write_text(out / "warptest.json", json.dumps(result.to_json(), indent=2) + "\n")
        plot_warptest(result, out / "warptest.png")
        print(f"wrote {out / 'warptest.png'} and {out / 'warptest.json'}")
    return 0 if result.passed else 1


def warptest(file=None, *, sampler=None, pdf=None, domain=None, samples=DEFAULT_SAMPLES, grid=None,
             alpha=DEFAULT_ALPHA, integral_tolerance=DEFAULT_INTEGRAL_TOLERANCE, seed=0, backend="auto",
             bsdf=None, cos_theta_o=0.5, roughness=0.3, ior=1.5, color=(0.8, 0.8, 0.8),
             distribution="ggx") -> WarptestResult:
    """Run one check (the command's options as arguments); raises LiftError on bad input."""
    from . import warp_kernels as wk

    start = time.perf_counter()
    if samples < 1000:
        raise LiftError(f"--samples must be at least 1000, not {samples}")
    if not 0.0 < alpha < 1.0:
        raise LiftError(f"--alpha must be in (0, 1), not {alpha}")
    if not integral_tolerance > 0.0:
        raise LiftError(f"--integral-tolerance must be positive, not {integral_tolerance}")
    if bsdf is None:
        if file is None or sampler is None or domain is None:
            raise LiftError("warptest needs FILE.glsl, --sampler NAME and --domain (or --bsdf MATERIAL)")
        target = wk.DOMAINS[domain]
        template, library, defines, uniforms = wk.WARP_SAMPLE_KERNEL, False, None, {}
        number_width = 2
    else:
        if domain not in (None, "sphere"):
            raise LiftError("--bsdf tests directions over the whole sphere: leave --domain out")
        if file is None and (sampler or pdf):
            raise LiftError("--sampler and --pdf name a FILE's functions; without FILE --bsdf tests "
                            "bsdf_sample and bsdf_pdf")
        if file is not None and sampler is None:
            raise LiftError("a BSDF FILE needs --sampler NAME (and --pdf NAME, default NAME_pdf)")
        target = wk.BSDF_DOMAIN
        material, wo, defines = bsdf_case(bsdf, cos_theta_o, roughness, ior, color, distribution)
        sampler, pdf = (sampler, pdf) if file is not None else ("bsdf_sample", "bsdf_pdf")
        template, library, uniforms = wk.BSDF_SAMPLE_KERNEL, True, {"u_material": material, "u_wo": wo}
        number_width = 4
    pdf = pdf or f"{sampler}_pdf"
    shape = grid or target.grid
    _check_name(sampler, "--sampler")
    _check_name(pdf, "--pdf")

    include = ""
    if file is not None:
        path = Path(file)
        if not path.is_file():
            raise LiftError("file not found", file)
        include = f'#include "{path.resolve()}"\n'
    signatures = SIGNATURES["bsdf" if bsdf is not None else target.point_type]
    where = "--bsdf" if bsdf is not None else f"--domain {target.name}"
    with _errors_in(file, "sampler", sampler, signatures[0], where):
        sample_kernel = wk.sample_kernel(template, sampler, point_type=target.point_type, defines=defines,
                                         include=include, library=library, name=KERNEL_NAME, backend=backend)
    with _errors_in(file, "pdf", pdf, signatures[1], where):
        pdf_kernel = wk.pdf_kernel(target, pdf, defines=defines, include=include, library=library,
                                   name=KERNEL_NAME, backend=backend)

    # ---- samples ----
    u = np.random.default_rng(seed).random((samples, number_width), dtype=np.float32)
    points = wk.run_sampler(sample_kernel, u, uniforms)
    if bsdf is None:
        with_density = np.ones(samples, bool)
        no_density = 0
        bsdf_info = None
    else:
        kind = points[:, 3]
        with_density = kind == 1.0
        rejected, delta = int(np.count_nonzero(kind == 0.0)), int(np.count_nonzero(kind == 2.0))
        no_density = rejected + delta
        bsdf_info = {"material": bsdf, "wo": [float(v) for v in wo], "roughness": roughness, "ior": ior,
                     "color": list(color), "distribution": distribution, "rejected": rejected, "delta": delta}
    a, b, misses = target.coordinates(points[with_density])
    outside_mask = np.zeros(len(a), bool)
    for mask in misses.values():
        outside_mask |= mask
    outside = {why: int(np.count_nonzero(mask)) for why, mask in misses.items()}
    from .chi2 import grid_histogram, pearson_chi2

    observed = grid_histogram(a[~outside_mask], b[~outside_mask], target.bounds, shape)

    # ---- the pdf over each cell ----
    integrals = wk.cell_integrals(pdf_kernel, uniforms, target.bounds, shape, samples,
                                  relative=CUBATURE_SHARE * integral_tolerance)
    expected = integrals.values * samples
    total = integrals.total

    # ---- Pearson's chi-square: the cells, and the samples with no density (BSDF) ----
    cells_obs, cells_exp = observed.ravel(), expected.ravel()
    if bsdf is not None:
        cells_obs = np.append(cells_obs, no_density)
        cells_exp = np.append(cells_exp, max(0.0, samples * (1.0 - total)))
    if np.isfinite(cells_exp).all():
        statistic, dof, histogram_p = pearson_chi2(cells_obs, cells_exp)
    else:
        statistic, dof, histogram_p = float("nan"), 0, 0.0
    in_zero = int(observed[integrals.values <= 0.0].sum())
    outside_count = sum(outside.values())
    p_value = 0.0 if outside_count or in_zero else histogram_p

    # ---- verdict ----
    reasons = []
    if outside_count:
        ways = ", ".join(f"{n} {why}" for why, n in outside.items() if n)
        reasons.append(f"{outside_count} samples outside the domain ({ways})")
    if in_zero:
        reasons.append(f"{in_zero} samples in cells where the pdf is 0")
    if not histogram_p > alpha:
        reasons.append(f"the histogram does not follow the pdf: p = {histogram_p:.3g} <= alpha = {alpha:g}")
    if not np.isfinite(total):
        reasons.append("the pdf's integral is not finite")
    elif bsdf is None and abs(total - 1.0) > integral_tolerance:
        reasons.append(f"the pdf integrates to {total:.6f} over the {target.name}, not 1 "
                       f"(tolerance {integral_tolerance:g})")
    elif bsdf is not None and total > 1.0 + integral_tolerance:
        reasons.append(f"the pdf integrates to {total:.6f} > 1 over the sphere (tolerance {integral_tolerance:g})")
    if integrals.least < 0.0:
        where = ", ".join(f"{n} = {v:.3g}" for n, v in zip(target.axes, integrals.least_at))
        reasons.append(f"the pdf is negative: {integrals.least:.3g} near {where}")
    if integrals.nonfinite:
        reasons.append(f"the pdf is NaN or Inf at {integrals.nonfinite} of its quadrature points")
    notes = []
    if dof + 1 < FEW_CELLS:
        notes.append(f"only {dof + 1} cells after pooling those that expect fewer than 5 samples: the histogram "
                     "sees little; raise --samples or coarsen --grid (the pdf integral is checked all the same)")
    return WarptestResult(
        file=None if file is None else str(file), sampler=sampler, pdf=pdf, domain=target.name, samples=samples,
        seed=seed, grid=tuple(shape), alpha=alpha, statistic=statistic, dof=dof, p_value=p_value,
        histogram_p_value=histogram_p, pdf_integral=total, quadrature_error=integrals.error,
        integral_tolerance=integral_tolerance, outside=outside, in_zero_pdf_cells=in_zero,
        pdf_least=integrals.least, pdf_least_at=tuple(float(v) for v in integrals.least_at),
        pdf_nonfinite=integrals.nonfinite, bsdf=bsdf_info, reasons=reasons, notes=notes,
        seconds=time.perf_counter() - start, observed=observed, expected=expected)


def summary(r: WarptestResult) -> str:
    what = r.file if r.file is not None else "shaders/lift/bsdf.glsl"
    lines = [f"warptest {what}: sampler {r.sampler}, pdf {r.pdf}, domain {r.domain}"]
    if r.bsdf is not None:
        m = r.bsdf
        params = "" if m["material"] == "diffuse" else f", roughness {m['roughness']:g}"
        params += f", ior {m['ior']:g}" if m["material"] in ("dielectric", "plastic") else ""
        params += ", Beckmann" if m["material"] == "conductor" and m["distribution"] == "beckmann" else ""
        lines.append(f"  material     {m['material']}{params}, wo = ({m['wo'][0]:.4f}, 0, {m['wo'][2]:.4f})")
        expected = max(0.0, r.samples * (1.0 - r.pdf_integral))
        lines.append(f"  no density   {m['rejected']} rejected + {m['delta']} delta samples "
                     f"(expected N (1 - pdf integral) = {expected:.1f})")
    lines += [
        f"  samples      {r.samples} (seed {r.seed}), grid {r.grid[0]}x{r.grid[1]} cells, {r.seconds:.1f} s",
        f"  chi-square   {r.statistic:.1f} with {r.dof} degrees of freedom, p = {r.p_value:.4g} (alpha {r.alpha:g})",
        f"  pdf integral {r.pdf_integral:.6f} (quadrature error ~ {r.quadrature_error:.1g}; "
        + ("must be 1" if r.bsdf is None else "at most 1") + f" within {r.integral_tolerance:g})",
        f"  outside      {sum(r.outside.values())} samples outside the domain",
    ]
    lines += [f"  note: {note}" for note in r.notes]
    if r.passed:
        lines.append("PASS: the samples follow the pdf")
    else:
        lines.append("REJECTED: " + "; ".join(r.reasons))
    return "\n".join(lines)


# ---- BSDF mode: a built-in material ---------------------------------------------------------
def bsdf_case(kind: str, cos_theta_o: float, roughness: float, ior: float, color, distribution: str):
    """(material uniform (4, 4), wo, defines) of a one-material scene, packed as a render packs it."""
    from .scene.model import Camera, Material, Scene
    from .scene.pack import pack_materials

    if not -1.0 <= cos_theta_o <= 1.0 or cos_theta_o == 0.0:
        raise LiftError(f"--cos-theta-o must be in [-1, 1] and not 0, not {cos_theta_o}")
    if cos_theta_o < 0.0 and kind != "dielectric":
        raise LiftError(f"--cos-theta-o {cos_theta_o}: a {kind} is one-sided; only a dielectric has an inside")
    if not 0.0 <= roughness <= 1.0:
        raise LiftError(f"--roughness must be in [0, 1], not {roughness}")
    if not ior > 1.0:
        raise LiftError(f"--ior must be > 1, not {ior}")
    if roughness == 0.0 and kind in ("conductor", "dielectric"):
        raise LiftError(f"a smooth {kind} is a delta lobe, with no density to test: give --roughness > 0")
    material = Material(name="warptest", type=kind, base_color=np.array(color, float), alpha=roughness ** 2,
                        ior=ior, distribution=distribution)
    scene = Scene(camera=Camera(position=[0, 0, 1], target=[0, 0, 0]), materials=[material])
    sin_o = float(np.sqrt(1.0 - cos_theta_o ** 2))
    defines = dict(EVERY_BSDF, HAS_BECKMANN=distribution == "beckmann")
    return pack_materials(scene)[0], (sin_o, 0.0, float(cos_theta_o)), defines


# ---- errors that name the student's file ----------------------------------------------------
SIGNATURES = {
    "vec2": ("vec2 {name}(vec2 u)", "float {name}(vec2 p)"),
    "vec3": ("vec3 {name}(vec2 u)", "float {name}(vec3 w)"),
    "bsdf": ("bool {name}(Material m, vec3 wo, vec3 u, out BsdfSample s)",
             "float {name}(Material m, vec3 wo, vec3 wi)"),
}


def _check_name(name: str, option: str) -> None:
    if not re.fullmatch(r"[A-Za-z_]\w*", name or ""):
        raise LiftError(f"{option} must name a GLSL function, not {name!r}")


class _errors_in:
    """Compile errors as the student wrote them: in FILE at its line, or, when the generated
    kernel cannot call the function (`role`: sampler or pdf), at the line that defines it
    (FILE alone when none does)."""

    def __init__(self, file, role: str, name: str, signature: str, domain: str):
        self.file, self.role, self.name, self.domain = file, role, name, domain
        self.signature = signature.format(name=name)

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if not isinstance(exc, ShaderError) or self.file is None:
            return False
        path = Path(self.file)
        if exc.path is not None and exc.path != KERNEL_NAME and Path(exc.path) == path.resolve():
            raise ShaderError(exc.message, self.file, exc.line) from None
        if exc.path != KERNEL_NAME:
            return False  # an error in a library file: as the compiler put it
        line = _definition_line(path.read_text(encoding="utf-8", errors="replace"), self.name)
        if line is None:
            raise ShaderError(f"no function '{self.name}' is defined (the {self.role}); warptest calls "
                              f"{self.signature}", self.file) from None
        # The compiler's first line; the signature above says what its list of candidates would.
        said = exc.message.splitlines()[0].removeprefix("error: ").split("; candidates are")[0]
        raise ShaderError(f"the {self.role} must be {self.signature} for {self.domain} (the compiler: {said})",
                          self.file, line) from None


def _definition_line(text: str, name: str) -> int | None:
    pattern = re.compile(rf"^\s*(?:highp\s+|mediump\s+)?\w+\s+{re.escape(name)}\s*\(")
    for number, line in enumerate(text.splitlines(), start=1):
        if pattern.match(line):
            return number
    return None
