"""A progress bar for long renders (tqdm: on a terminal, or its notebook form in a Jupyter
kernel): samples per pixel, elapsed time and the estimated relative error of the image so far
(lift_gl/error_estimate.py), which is read back from the GPU at most once a second."""
from __future__ import annotations

import sys
import time


class RenderProgress:
    """Call it as Renderer.render's `progress(renderer, done)`; close() at the end."""

    def __init__(self, spp: int | None = None, seconds: float | None = None, desc: str = "render",
                 file=None, error_every: float = 1.0, delay: float = 0.5):
        tqdm, notebook = _tqdm_class()
        self.seconds = seconds
        self.error_every = error_every
        self._last_error_time = -float("inf")
        self._error_text = "est. error -"
        self._start = time.perf_counter()
        total = spp if seconds is None else float(seconds)
        if notebook:  # an ipywidgets bar in the cell's output, kept when done
            self.bar = tqdm(total=total, desc=desc, leave=True)
        else:
            self.bar = tqdm(total=total, desc=desc, file=file if file is not None else sys.stderr, leave=False,
                            delay=delay, bar_format="{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]")

    def __call__(self, renderer, done: int) -> None:
        now = time.perf_counter()
        if now - self._last_error_time >= self.error_every:
            estimate = renderer.estimate_error()
            if estimate is not None:
                self._error_text = f"est. error {100 * estimate.rel_std_error:.2f}%"
            self._last_error_time = now
        elapsed = now - self._start
        self.bar.n = done if self.seconds is None else min(elapsed, self.seconds)
        self.bar.set_postfix_str(f"{renderer.stats.spp} spp, {elapsed:.1f} s, {self._error_text}", refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        self.bar.close()


def in_notebook() -> bool:
    """True inside a Jupyter kernel (IPython's ZMQ shell), whatever the front end."""
    shell = sys.modules.get("IPython")
    if shell is None:
        return False
    try:
        ip = shell.get_ipython()
    except AttributeError:
        return False
    return ip is not None and type(ip).__name__ == "ZMQInteractiveShell"


def _tqdm_class():
    """tqdm's notebook bar in a Jupyter kernel with ipywidgets, else the terminal one; and
    whether it is the notebook's."""
    if in_notebook():
        try:
            import ipywidgets  # noqa: F401  (tqdm.notebook needs it to draw)
            from tqdm.notebook import tqdm as notebook_tqdm
        except ImportError:
            pass
        else:
            return notebook_tqdm, True
    from tqdm import tqdm

    return tqdm, False
