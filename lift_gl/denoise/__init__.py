"""Denoisers: they take the accumulated radiance and the G-buffer's guides and return a
cleaner radiance image.

A denoiser has a `name` and a method

    denoise(color, albedo, normal, depth=None, variance=None) -> color

on numpy arrays: color, albedo and normal are (H, W, 3) float32 (linear radiance, first-hit
albedo, first-hit normal in world space), depth and variance (H, W) float32 or None. Each
denoiser demodulates by albedo itself (lift_gl/denoise/demodulate.py) where it wants to.
"""
