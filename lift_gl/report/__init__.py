"""Error against run time (`lift-gl compare`) and frame timings (`lift-gl bench`).

configurations.py  what to compare: integrator, parameters, denoiser mode
progressive.py     one progressive render with checkpoints (time, spp, image)
reference.py       the reference image: a file, or a long pt render cached on disk
statistics.py      confidence intervals over seeds, time to reach an error
compare.py         the `compare` command: runs, metrics.csv, plot, contact sheet, report.md
bench.py           the `bench` command: per-pass times, paths/s, rays/s, BVH build time
gpu_clock.py       an NVIDIA GPU's SM clock (NVML) and the warm-up that waits for it to rise
"""
