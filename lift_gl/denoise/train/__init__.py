"""Training the ONNX denoiser (docs/denoiser.md): `python -m lift_gl.denoise.train`.

scenes.py and render_data.py need no torch; model.py, loss.py, train.py and export.py need
the `train` extra (torch, onnx)."""
