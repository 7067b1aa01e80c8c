"""The picture of `lift-gl warptest`: observed counts, expected counts, and their difference
in standard deviations, (obs - exp) / sqrt(exp), on the test's grid. matplotlib is imported
here only, with the Agg backend (no display needed)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .atomic import atomic_path

# The difference panel's colour scale: at least +-4 standard deviations, so that noise of a
# passing test looks pale and a real misfit stands out.
LEAST_RANGE = 4.0
PEAKED = 20.0  # a largest count this many times the median one: counts drawn on a log scale


def plot_warptest(result, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm, Normalize

    observed, expected = result.observed, result.expected
    # Cells over which the pdf is 0 and no sample fell (the disk's corners, a BSDF's
    # impossible directions) are left blank; samples in them show in the difference panel.
    blank = (expected <= 0) & (observed == 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(expected > 0, (observed - expected) / np.sqrt(expected), np.where(observed > 0, np.inf, 0.0))
    z_finite = z[np.isfinite(z) & ~blank]
    span = max(LEAST_RANGE, float(np.abs(z_finite).max()) if z_finite.size else 0.0)
    z = np.clip(z, -span, span)
    top = max(float(observed.max()), float(expected.max()), 1.0)

    directions = result.domain in ("sphere", "hemisphere")
    (a0, a1), (b0, b1) = _bounds(result)
    if directions:  # phi across, cos theta up
        extent, transpose, labels = (b0, b1, a0, a1), False, ("phi", "cos theta")
    else:            # x across, y up
        extent, transpose, labels = (a0, a1, b0, b1), True, ("x", "y")

    def image(values):
        values = np.where(blank, np.nan, values)
        return values.T if transpose else values

    fig, axes = plt.subplots(1, 3, figsize=(12.6, 3.7) if directions else (11.6, 3.9))
    fig.subplots_adjust(left=0.06, right=0.955, bottom=0.14, top=0.8, wspace=0.42)  # fixed: layout engines are slow
    # A peaked density (a glossy lobe) on a log scale, where its tails stay visible.
    positive = expected[expected > 0]
    peaked = positive.size > 0 and top > PEAKED * float(np.median(positive))
    counts = LogNorm(vmin=1.0, vmax=top) if peaked else Normalize(0.0, top)
    scale = " (log scale)" if peaked else ""
    if peaked:
        observed, expected = np.maximum(observed, 1.0), np.maximum(expected, 1.0)  # 0 as the scale's floor
    panels = ((axes[0], image(observed), "observed samples" + scale, "viridis", counts),
              (axes[1], image(expected), "expected: N x pdf's integral" + scale, "viridis", counts),
              (axes[2], image(z), "(obs - exp) / sqrt(exp)", "RdBu_r", Normalize(-span, span)))
    for ax, values, title, cmap, norm in panels:
        shown = ax.imshow(values, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm,
                          interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.03)
    verdict = "PASS" if result.passed else "REJECTED"
    name = Path(result.file).name if result.file else "bsdf.glsl"
    what = f"{result.bsdf['material']}, cos theta_o {result.bsdf['wo'][2]:.3g}" if result.bsdf else result.domain
    rejected = f"; {result.bsdf['rejected']} rejected" if result.bsdf else ""
    fig.suptitle(f"{name}: {result.sampler} / {result.pdf} ({what}), N = {result.samples}\n"
                 f"{verdict}: chi2 = {result.statistic:.1f}, {result.dof} dof, p = {result.p_value:.3g}; "
                 f"pdf integral {result.pdf_integral:.5f}; {sum(result.outside.values())} outside" + rejected,
                 fontsize=10, color="black" if result.passed else "firebrick")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=80)
    plt.close(fig)


def _bounds(result):
    from .warp_kernels import BSDF_DOMAIN, DOMAINS

    return BSDF_DOMAIN.bounds if result.bsdf is not None else DOMAINS[result.domain].bounds
