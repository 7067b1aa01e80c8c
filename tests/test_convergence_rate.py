"""relMSE of an unbiased estimator falls like 1/spp on a white furnace, whose exact image is
known (a fully covered pixel of a diffuse sphere of albedo 0.8 is 0.8): exactly for `pt`
with independent samples (low_discrepancy=false); at least as fast for the default `pt`,
whose low-discrepancy (Owen-scrambled Sobol) samples are stratified over a pixel's samples.

Each seed's progressive render gives relMSE at 1, 2, 4, ..., 256 spp and a least-squares
slope of log relMSE against log spp. Checkpoints of one render share samples, so the
regression's own standard error would be wrong; independent seeds give independent slopes,
and their spread gives the standard error of the mean slope. Expected: exactly -1 for
independent samples (E[relMSE] = sigma_rel^2 / spp)."""
from __future__ import annotations

import numpy as np
from scipy import stats

from conftest import furnace_scene, sphere_pixel_cosines
from lift_gl.metrics import rel_mse
from lift_gl.renderer import Renderer
from lift_gl.scene import Material

SIZE = (48, 48)
SEEDS = range(1, 9)
CHECKPOINTS = [2 ** k for k in range(9)]  # 1 .. 256 spp
P_VALUE = 1e-3  # two-sided: a correct renderer fails this test once in a thousand runs


def slope_of_one_render(scene, inside, seed, params) -> float:
    renderer = Renderer(scene, size=SIZE, integrator="pt", seed=seed, params=params)
    errors = []
    for spp in CHECKPOINTS:
        image = renderer.render(spp=spp - renderer.stats.spp)
        errors.append(rel_mse(image[inside], np.full_like(image[inside], 0.8)))
    assert renderer.stats.spp == CHECKPOINTS[-1] and renderer.stats.dropped_samples == 0
    renderer.release()
    slope, _ = np.polyfit(np.log(CHECKPOINTS), np.log(errors), 1)
    return float(slope)


def slopes_of(params):
    scene = furnace_scene(Material("grey", "diffuse", base_color=[0.8] * 3), size=SIZE)
    inside = np.all(np.isfinite(sphere_pixel_cosines(scene, SIZE)), axis=-1)
    assert inside.sum() > 500
    slopes = np.array([slope_of_one_render(scene, inside, seed, params) for seed in SEEDS])
    return slopes.mean(), slopes.std(ddof=1) / np.sqrt(slopes.size), slopes


def test_independent_samples_rel_mse_falls_like_one_over_spp():
    mean, standard_error, slopes = slopes_of({"low_discrepancy": False})
    t_crit = stats.t.ppf(1 - P_VALUE / 2, df=len(slopes) - 1)
    assert abs(mean + 1) < t_crit * standard_error, (mean, standard_error, slopes)
    # The test has power: a slope of -0.9 or -1.1 (error falling like spp^-0.9) would fail.
    assert t_crit * standard_error < 0.1, standard_error


def test_pt_rel_mse_falls_at_least_like_one_over_spp():
    mean, standard_error, slopes = slopes_of({})
    t_crit = stats.t.ppf(1 - P_VALUE, df=len(slopes) - 1)  # one-sided: faster is allowed
    assert mean < -1 + t_crit * standard_error, (mean, standard_error, slopes)
    assert t_crit * standard_error < 0.1, standard_error
