"""Does an estimator converge to the reference's image? A test of bias, not of noise.

An estimate of an image's expectation is held block by block: the mean of each block of
pixels, per channel (R, G, B and luminance Y), and the variance of that mean, with its degrees
of freedom. Two sources give it:

- independent renders (seeds): the seeds' spread gives the variance, K - 1 degrees of freedom
  (`from_seeds`); this is what `lift-gl grade` uses;
- one render's per-pixel variance of its mean, estimated from the accumulation's two halves
  (lift_gl/error_estimate.py: one degree of freedom a pixel and channel, pooled over the block
  with Satterthwaite's count; `from_pixel_variance`); what `lift-gl compare` uses for its
  reference and its runs, which keep no per-seed images of the reference;
- an analytic image (variance 0, `exact`), where the answer is known (a white furnace).

Two estimates are compared by Welch's t of each mean difference, converted through its own t
distribution to a two-sided p-value and an equivalent normal z (so that blocks of different
degrees of freedom can be pooled). Three tests, each at a third of the family's level alpha
(Bonferroni):

1. the whole image's mean, per channel (R, G, B, Y; Sidak over the four): a bias spread over
   the image, the most powerful test for a constant factor (a pdf off by a constant);
2. the most extreme block, over every block and channel R, G, B (Sidak): a bias in one place
   (a caustic missing, one material wrong); each block's variance is at least the reference's
   times the median ratio of the two (moderated_block_variance says why);
3. the sum of the blocks' squared luminance z, chi-square with one degree of freedom a block:
   a small bias spread over many blocks, none of which stands out alone.

The channels of one block are correlated (the same paths carry them), so only test 3 needs
independence, and it uses luminance alone; Sidak is conservative under the positive dependence
of the others. A block where neither estimate varies (the background of a furnace, an emitter
seen directly) must agree to float rounding, or it is infinitely significant.

A difference within `tolerance` (relative, default 1% for the image's mean, 5% for a block's:
BLOCK_TOLERANCE says why) of the reference's mean is allowed: each t
counts only the part of the difference beyond it (a composite null hypothesis, tested at its
boundary). Under the hypothesis that both have the same expectation, the family rejects with probability
at most alpha (up to the normal approximation of each block's t, which needs the blocks' means
to be roughly normal: many samples per block, as a few thousand give for any finite-variance
estimator). A consistent verdict says nothing of noise: an estimator 300x noisier than the
reference is consistent; the `resolution` says how large a bias the test would have seen.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
CHANNELS = ("R", "G", "B", "Y")
Y = 3
# Blocks whose estimates have no variance must agree to this (relative), float32 rounding of a
# mean of equal values.
EXACT_TOLERANCE = 1e-5
# A relative difference of expectations this small is not called a bias: estimators that are
# both right up to a path-length cut-off (max_depth counted one bounce apart) or a float
# rounding differ by less. The tests ask whether the difference exceeds it.
BIAS_TOLERANCE = 0.01
# One block's mean is held to a wider tolerance. A block holds a few thousand samples, and an
# estimator with rare large samples (light sampling alone on a glossy surface, a caustic found
# by chance) skews its block means: in a block where the seeds happened to miss them, the mean
# and its spread are both low, and t is far from normal in its tail. Seen with a correct
# estimator at the grader's defaults: a block 3.5% dark at z = -5.3. The image's mean pools all
# blocks, is close to normal, and keeps the tight tolerance.
BLOCK_TOLERANCE = 0.05


def with_luminance(image: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 4): R, G, B and luminance Y, in float64."""
    image = np.asarray(image, np.float64)
    return np.concatenate([image, (image @ LUMINANCE)[..., None]], axis=-1)


@dataclass
class Blocks:
    """How an image is cut into blocks: a label per pixel (-1: left out), and their count."""
    labels: np.ndarray  # (H, W) int
    count: int
    shape: tuple        # (rows, columns) of the block grid
    size: int           # block side in pixels

    @classmethod
    def grid(cls, height: int, width: int, size: int, mask: np.ndarray | None = None) -> "Blocks":
        """size x size blocks (the last row and column smaller where the image does not divide);
        pixels where mask is False are left out, and so are blocks left empty."""
        rows, cols = -(-height // size), -(-width // size)
        y, x = np.mgrid[0:height, 0:width]
        labels = (y // size) * cols + x // size
        if mask is not None:
            labels = np.where(mask, labels, -1)
        return cls(labels=labels, count=rows * cols, shape=(rows, cols), size=size)

    def sums(self, values: np.ndarray) -> np.ndarray:
        """(..., H, W, C) -> (..., blocks, C): sums over each block's pixels."""
        lead = values.shape[:-3]
        channels = values.shape[-1]
        flat = values.reshape(*lead, -1, channels)
        keep = self.labels.ravel() >= 0
        out = np.zeros((*lead, self.count, channels))
        index = self.labels.ravel()[keep]
        for c in range(channels):
            taken = flat[..., keep, c]
            if lead:
                for k in np.ndindex(*lead):
                    out[k + (slice(None), c)] = np.bincount(index, weights=taken[k], minlength=self.count)
            else:
                out[:, c] = np.bincount(index, weights=taken, minlength=self.count)
        return out

    @property
    def pixels(self) -> np.ndarray:
        """Pixels in each block, (blocks,)."""
        return np.bincount(self.labels.ravel()[self.labels.ravel() >= 0], minlength=self.count)

    @property
    def used(self) -> np.ndarray:
        return self.pixels > 0


@dataclass
class Estimate:
    """An image's expectation as estimated, per block and for the whole image (channels R, G,
    B, Y): means, variances of the means, degrees of freedom (inf: known exactly)."""
    mean: np.ndarray         # (blocks, 4)
    var: np.ndarray          # (blocks, 4)
    dof: np.ndarray          # (blocks, 4)
    image_mean: np.ndarray   # (4,)
    image_var: np.ndarray    # (4,)
    image_dof: np.ndarray    # (4,)
    blocks: Blocks
    samples: float = math.nan  # samples per pixel behind the estimate (all seeds together)

    @classmethod
    def from_seeds(cls, images: np.ndarray, blocks: Blocks, spp_per_seed: float = math.nan) -> "Estimate":
        """images: (K, H, W, 3) independent renders, K >= 2."""
        images = with_luminance(images)
        k = images.shape[0]
        if k < 2:
            raise ValueError("the spread of independent renders needs at least two of them")
        pixels = blocks.pixels[:, None]
        used = blocks.used
        per_seed = blocks.sums(images)[:, used] / pixels[used]         # (K, blocks, 4)
        whole = per_seed * pixels[used] / pixels[used].sum()
        per_seed_image = whole.sum(axis=1)                             # (K, 4)
        dof = np.full(per_seed.shape[1:], k - 1.0)
        return cls(mean=per_seed.mean(axis=0), var=per_seed.var(axis=0, ddof=1) / k, dof=dof,
                   image_mean=per_seed_image.mean(axis=0), image_var=per_seed_image.var(axis=0, ddof=1) / k,
                   image_dof=np.full(4, k - 1.0), blocks=blocks, samples=k * spp_per_seed)

    @classmethod
    def from_pixel_variance(cls, mean: np.ndarray, variance: np.ndarray, blocks: Blocks,
                            samples: float = math.nan) -> "Estimate":
        """mean: (H, W, 3) or (H, W, 4); variance: the variance of each pixel's mean, same
        shape, each an unbiased estimate of one degree of freedom (NaN: unknown, left out)."""
        mean = with_luminance(mean) if mean.shape[-1] == 3 else np.asarray(mean, np.float64)
        variance = np.asarray(variance, np.float64)
        if variance.shape[-1] == 3:
            raise ValueError("the luminance's variance needs the channels' covariances: pass 4 channels")
        known = np.isfinite(variance).all(axis=-1)
        blocks = Blocks(np.where(known, blocks.labels, -1), blocks.count, blocks.shape, blocks.size)
        used = blocks.used
        pixels = blocks.pixels[used][:, None].astype(np.float64)
        v = np.where(np.isfinite(variance), variance, 0.0)
        sums, var_sums, var_squares = (blocks.sums(a)[used] for a in (mean, v, v * v))
        n = pixels.sum()
        with np.errstate(divide="ignore", invalid="ignore"):
            dof = np.where(var_squares > 0, var_sums ** 2 / var_squares, math.inf)
            image_dof = np.where(var_squares.sum(0) > 0, var_sums.sum(0) ** 2 / var_squares.sum(0), math.inf)
        return cls(mean=sums / pixels, var=var_sums / pixels ** 2, dof=dof, image_mean=sums.sum(0) / n,
                   image_var=var_sums.sum(0) / n ** 2, image_dof=image_dof, blocks=blocks,
                   samples=samples)

    @classmethod
    def combine(cls, estimates: list["Estimate"]) -> "Estimate":
        """The mean of independent estimates on the same blocks (runs of several seeds)."""
        k = len(estimates)
        first = estimates[0]

        def pool(var_name, dof_name):
            v = np.stack([getattr(e, var_name) for e in estimates]) / k ** 2
            d = np.stack([getattr(e, dof_name) for e in estimates])
            total = v.sum(0)
            with np.errstate(divide="ignore", invalid="ignore"):
                terms = np.where(np.isfinite(d), v ** 2 / d, 0.0).sum(0)
                return total, np.where(terms > 0, total ** 2 / terms, math.inf)

        var, dof = pool("var", "dof")
        image_var, image_dof = pool("image_var", "image_dof")
        return cls(mean=np.mean([e.mean for e in estimates], axis=0), var=var, dof=dof,
                   image_mean=np.mean([e.image_mean for e in estimates], axis=0), image_var=image_var,
                   image_dof=image_dof, blocks=first.blocks, samples=sum(e.samples for e in estimates))

    def with_larger_variance(self, other: "Estimate") -> "Estimate":
        """The same means, each variance the larger of this estimate's and `other`'s (two
        estimates of the same means' noise: the larger is the safer where the noise has rare
        large samples that one of them missed), with its degrees of freedom."""
        take = other.var > self.var
        take_image = other.image_var > self.image_var
        return Estimate(mean=self.mean, var=np.where(take, other.var, self.var), dof=np.where(take, other.dof, self.dof),
                        image_mean=self.image_mean, image_var=np.where(take_image, other.image_var, self.image_var),
                        image_dof=np.where(take_image, other.image_dof, self.image_dof), blocks=self.blocks,
                        samples=self.samples)

    @classmethod
    def exact(cls, image: np.ndarray, blocks: Blocks) -> "Estimate":
        """A known image (NaN pixels: unknown, left out of every block)."""
        image = with_luminance(image)
        known = np.isfinite(image).all(axis=-1)
        blocks = Blocks(np.where(known, blocks.labels, -1), blocks.count, blocks.shape, blocks.size)
        used = blocks.used
        pixels = blocks.pixels[used][:, None].astype(np.float64)
        sums = blocks.sums(np.where(np.isfinite(image), image, 0.0))[used]
        zeros = np.zeros_like(sums)
        return cls(mean=sums / pixels, var=zeros, dof=np.full_like(sums, math.inf),
                   image_mean=sums.sum(0) / pixels.sum(), image_var=np.zeros(4), image_dof=np.full(4, math.inf),
                   blocks=blocks, samples=math.inf)


@dataclass
class Test:
    name: str
    p: float          # the test's p-value (already corrected within the test)
    level: float      # it rejects when p < level
    detail: str = ""

    @property
    def rejects(self) -> bool:
        return self.p < self.level


@dataclass
class Consistency:
    """The verdict of `compare_estimates`: whether the two expectations agree, and the sizes
    a student or a report needs."""
    consistent: bool
    alpha: float
    tolerance: float
    z: float                 # signed difference in standard errors (Welch's t): the image's luminance,
                             # or the worst block's if only it rejects
    bias: float              # relative: (mean - reference) / reference, image luminance
    resolution: float        # relative bias the image test detects at its level (one side)
    where: str               # "image", "block" or "blocks" (what rejected), "" when consistent
    tests: list = field(default_factory=list)
    block_z: np.ndarray | None = None      # (rows, cols) luminance z per block, NaN: left out
    block_bias: np.ndarray | None = None   # (rows, cols) relative luminance difference per block
    worst_block: tuple | None = None       # (row, col) of the most extreme block
    variance_ratio: float = math.nan       # estimate's per-sample variance / reference's (Y)

    @property
    def direction(self) -> str:
        return "too bright" if self.z > 0 else "too dark"

    def sentence(self) -> str:
        if self.consistent:
            return (f"consistent with the reference (image z = {self.z:+.2f}; a bias of "
                    f"{100 * self.resolution:.2g}% or more would have been seen)")
        failed = "; ".join(f"{t.name}: p = {t.p:.2g} < {t.level:.2g}" for t in self.tests if t.rejects)
        size = f"{100 * self.bias:+.2f}% overall" if math.isfinite(self.bias) else ""
        where = {"image": "over the image", "block": "in one region", "blocks": "spread over many blocks"}[self.where]
        return f"biased, {self.direction} {where} (z = {self.z:+.1f}, {size}); {failed}"


def _z_of_t(t: np.ndarray, dof: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided p-values of t with `dof` degrees of freedom and the normal z of equal p, signed."""
    from scipy import stats

    t = np.asarray(t, np.float64)
    dof = np.broadcast_to(np.asarray(dof, np.float64), t.shape)
    finite_dof = np.isfinite(dof)
    with np.errstate(invalid="ignore", over="ignore"):
        log_p = np.where(finite_dof, stats.t.logsf(np.abs(t), np.where(finite_dof, dof, 1.0)),
                         stats.norm.logsf(np.abs(t))) + math.log(2.0)
    log_p = np.minimum(log_p, 0.0)
    p = np.exp(log_p)
    z = np.where(np.isinf(t), np.inf, stats.norm.isf(np.clip(np.exp(log_p - math.log(2.0)), 1e-300, 0.5)))
    return p, np.sign(t) * z


def _welch(a_mean, a_var, a_dof, b_mean, b_var, b_dof, tolerance: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """t of a - b, its part beyond `tolerance` x |b| only, and Welch-Satterthwaite's degrees
    of freedom. No variance on either side: 0 where the means agree to rounding, infinite
    where they do not."""
    raw = a_mean - b_mean
    diff = np.sign(raw) * np.maximum(np.abs(raw) - tolerance * np.abs(b_mean), 0.0)
    var = a_var + b_var
    scale = np.maximum(np.abs(a_mean), np.abs(b_mean))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(var > 0, diff / np.sqrt(var),
                     np.where(np.abs(diff) <= EXACT_TOLERANCE * scale + 1e-12, 0.0, np.sign(diff) * np.inf))
        terms = np.where(np.isfinite(a_dof), a_var ** 2 / a_dof, 0.0) + np.where(np.isfinite(b_dof), b_var ** 2 / b_dof, 0.0)
        dof = np.where(terms > 0, var ** 2 / terms, math.inf)
    return t, dof


def moderated_block_variance(estimate: Estimate, reference: Estimate) -> np.ndarray:
    """The estimate's block variances, each at least the reference's times the median ratio of
    the two over all blocks (per channel). An estimator with rare large samples (roulette from
    the first bounce, a caustic found by chance) whose seeds missed them in one block shows a
    mean there that is low and a spread that is low too: alone, that block's t is far out in a
    tail the t distribution does not have. Its neighbours' ratio to the reference says how
    noisy it really is. Only ever raises a variance: the tests stay at their level or below."""
    ref = reference.var
    usable = ref > 0
    ratio = np.zeros(ref.shape[1])
    for c in range(ref.shape[1]):
        if usable[:, c].any():
            ratio[c] = float(np.median(estimate.var[usable[:, c], c] / ref[usable[:, c], c]))
    return np.maximum(estimate.var, ratio[None, :] * ref)


def _sidak(p_min: float, count: int) -> float:
    """The chance that the least of `count` independent uniform p-values is at most p_min."""
    if count <= 1:
        return float(p_min)
    return float(-np.expm1(count * np.log1p(-min(p_min, 1.0 - 1e-16))))


def compare_estimates(estimate: Estimate, reference: Estimate, alpha: float = 1e-3,
                      tolerance: float = BIAS_TOLERANCE, block_tolerance: float | None = BLOCK_TOLERANCE) -> Consistency:
    """Whether `estimate` and `reference` (same Blocks) have the same expectation, up to a
    relative `tolerance`: the family of three tests rejects with probability at most alpha
    when no mean differs by more than tolerance (the image's) or block_tolerance (a block's;
    None: the same as the image's) times the reference's."""
    if block_tolerance is None:
        block_tolerance = tolerance
    from scipy import stats

    if not np.array_equal(estimate.blocks.labels, reference.blocks.labels):
        raise ValueError("the two estimates were made on different pixels: make both on the same Blocks")
    level = alpha / 3.0
    tests = []

    # 1. The image's mean, per channel.
    t_img, dof_img = _welch(estimate.image_mean, estimate.image_var, estimate.image_dof,
                            reference.image_mean, reference.image_var, reference.image_dof, tolerance)
    p_img, z_img = _z_of_t(t_img, dof_img)
    k = int(np.argmin(p_img))
    tests.append(Test("image mean", _sidak(float(p_img[k]), 4), level,
                      f"channel {CHANNELS[k]}: z = {z_img[k]:+.2f}"))

    # 2. The most extreme block, channels R, G, B.
    block_var = moderated_block_variance(estimate, reference)
    t_blk, dof_blk = _welch(estimate.mean, block_var, estimate.dof, reference.mean, reference.var, reference.dof,
                            block_tolerance)
    p_blk, z_blk = _z_of_t(t_blk, dof_blk)
    rgb = p_blk[:, :3]
    worst = np.unravel_index(int(np.argmin(rgb)), rgb.shape) if rgb.size else (0, 0)
    n_tests = rgb.size
    tests.append(Test("worst block", _sidak(float(rgb[worst]) if rgb.size else 1.0, n_tests), level,
                      f"{n_tests} block-channels; block z = {z_blk[worst]:+.2f}" if rgb.size else "no blocks"))

    # 3. The blocks' luminance z^2 together.
    zy = z_blk[:, Y]
    finite = np.isfinite(zy)
    chi2 = float(np.sum(zy[finite] ** 2)) if finite.all() else math.inf
    p_sum = float(stats.chi2.sf(chi2, zy.size)) if zy.size and math.isfinite(chi2) else (0.0 if zy.size else 1.0)
    tests.append(Test("blocks together", p_sum, level, f"sum z^2 = {chi2:.1f} over {zy.size} blocks"))

    consistent = not any(t.rejects for t in tests)
    ref_y = reference.image_mean[Y]
    with np.errstate(divide="ignore", invalid="ignore"):
        bias = float((estimate.image_mean[Y] - ref_y) / ref_y) if ref_y != 0 else math.nan
        z_crit = float(stats.norm.isf(level / 2.0 / 4.0))
        resolution = tolerance + float(z_crit * math.sqrt(estimate.image_var[Y] + reference.image_var[Y]) / abs(ref_y)) \
            if ref_y != 0 else math.nan
    # What a person reads: the whole difference in standard errors (Welch's t itself, tolerance
    # not taken off; the tests above decide by p-values, these only report).
    z_img, _ = _welch(estimate.image_mean, estimate.image_var, estimate.image_dof,
                      reference.image_mean, reference.image_var, reference.image_dof)
    z_blk, _ = _welch(estimate.mean, block_var, estimate.dof, reference.mean, reference.var, reference.dof)
    zy = z_blk[:, Y]
    rejected = [t.name for t in tests if t.rejects]
    if consistent:
        z, where = float(z_img[Y]), ""
    elif "image mean" in rejected:
        z, where = float(z_img[k]), "image"
    elif "worst block" in rejected:
        z, where = float(z_blk[worst]), "block"
    else:
        z, where = float(z_img[Y]), "blocks"
    rows, cols = estimate.blocks.shape
    grid = np.full(rows * cols, np.nan)
    grid[np.flatnonzero(estimate.blocks.used)] = zy
    relative = np.full(rows * cols, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative[np.flatnonzero(estimate.blocks.used)] = (estimate.mean[:, Y] - reference.mean[:, Y]) / reference.mean[:, Y]
    worst_rc = None
    if rgb.size:
        index = int(np.flatnonzero(estimate.blocks.used)[worst[0]])
        worst_rc = (index // cols, index % cols)
    ratio = math.nan
    if math.isfinite(estimate.samples) and math.isfinite(reference.samples) and reference.var[:, Y].sum() > 0:
        ratio = float(estimate.var[:, Y].sum() * estimate.samples / (reference.var[:, Y].sum() * reference.samples))
    return Consistency(consistent=consistent, alpha=alpha, tolerance=tolerance, z=z, bias=bias, resolution=resolution,
                       where=where, tests=tests, block_z=grid.reshape(rows, cols),
                       block_bias=relative.reshape(rows, cols),
                       worst_block=worst_rc, variance_ratio=ratio)
