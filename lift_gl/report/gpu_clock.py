"""The GPU's SM clock, read through NVML (NVIDIA's management library, which the driver
installs), and a warm-up that keeps the GPU busy until the clock has risen.

Why: an idle NVIDIA GPU drops its SM clock (the H100 of issue 10: 345 MHz idle, 1980 MHz
under load) and raises it only after some hundreds of milliseconds of sustained work, so a
short timed run that starts from idle (a renderer just built, its BVH uploaded) runs partly
at a fraction of the clock: the same frame measured 2.6 ms in one phase of a device call and
7 ms in another (docs/gpu.md, "The GPU's clock"). Benchmarks warm up with `warm_up` and
record the clock they ran at (`ClockReader.sample`).

No NVML (no NVIDIA driver, llvmpipe, another vendor): every reading is None and `warm_up`
runs its minimum number of steps. Nothing here changes the GPU's settings.
"""
from __future__ import annotations

import ctypes
import time

NVML_CLOCK_SM = 1
NVML_SUCCESS = 0


class ClockReader:
    """SM clock readings of one NVIDIA GPU: the one whose name is in `renderer_name`, the GL
    renderer string (a GL that is not NVIDIA's, say an integrated GPU beside an NVIDIA one,
    gets no readings), or with None (a CUDA program such as Mitsuba) device 0. Every method
    returns None where there is nothing to read."""

    def __init__(self, renderer_name: str | None = None, library: str = "libnvidia-ml.so.1"):
        self._lib = self._handle = None
        if renderer_name is not None and "nvidia" not in renderer_name.lower():
            return
        try:
            lib = ctypes.CDLL(library)
            if lib.nvmlInit_v2() != NVML_SUCCESS:
                return
            count = ctypes.c_uint(0)
            lib.nvmlDeviceGetCount_v2(ctypes.byref(count))
            handles = []
            for i in range(count.value):
                h = ctypes.c_void_p()
                if lib.nvmlDeviceGetHandleByIndex_v2(i, ctypes.byref(h)) == NVML_SUCCESS:
                    handles.append(h)
            if not handles:
                return
            self._lib, self._handle = lib, handles[0]
            for h in handles:  # several GPUs: the one GL renders on, by name
                name = ctypes.create_string_buffer(96)
                if lib.nvmlDeviceGetName(h, name, 96) == NVML_SUCCESS and name.value.decode() in (renderer_name or ""):
                    self._handle = h
                    break
        except (OSError, AttributeError):
            self._lib = self._handle = None

    @property
    def available(self) -> bool:
        return self._handle is not None

    def _clock(self, getter: str) -> int | None:
        if self._handle is None:
            return None
        mhz = ctypes.c_uint(0)
        if getattr(self._lib, getter)(self._handle, NVML_CLOCK_SM, ctypes.byref(mhz)) != NVML_SUCCESS:
            return None
        return int(mhz.value)

    def sm_mhz(self) -> int | None:
        """The SM clock now."""
        return self._clock("nvmlDeviceGetClockInfo")

    def max_sm_mhz(self) -> int | None:
        """The highest SM clock the GPU may boost to."""
        return self._clock("nvmlDeviceGetMaxClockInfo")

    def reasons(self) -> int | None:
        """NVML's bit mask of why the clock is held down now (1: idle; 4: power cap; see
        nvmlClocksEventReasons), or None."""
        if self._handle is None:
            return None
        mask = ctypes.c_ulonglong(0)
        getter = getattr(self._lib, "nvmlDeviceGetCurrentClocksEventReasons", None) or \
            getattr(self._lib, "nvmlDeviceGetCurrentClocksThrottleReasons", None)
        if getter is None or getter(self._handle, ctypes.byref(mask)) != NVML_SUCCESS:
            return None
        return int(mask.value)

    def sample(self) -> dict:
        """What a benchmark records beside a timing: {"sm_mhz", "max_sm_mhz"} (None without NVML)."""
        return {"sm_mhz": self.sm_mhz(), "max_sm_mhz": self.max_sm_mhz()}


def warm_up(step, clock: ClockReader, target: float = 0.9, min_steps: int = 0, max_seconds: float = 3.0,
            now=time.perf_counter) -> dict:
    """Run `step()` (GPU work, finished) at least `min_steps` times, and more while the SM
    clock reads below `target` of its maximum, for at most `max_seconds`. Returns what
    happened: steps, seconds, the last reading and whether the clock is there (None without
    NVML, where only the `min_steps` run)."""
    peak = clock.max_sm_mhz()

    def there(mhz):
        return None if mhz is None or not peak else mhz >= target * peak

    start = now()
    steps, mhz = 0, clock.sm_mhz()
    while steps < min_steps or (there(mhz) is False and now() - start < max_seconds):
        step()
        steps += 1
        mhz = clock.sm_mhz()
    return {"steps": steps, "seconds": now() - start, "sm_mhz": mhz, "max_sm_mhz": peak, "reached": there(mhz)}
