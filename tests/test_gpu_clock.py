"""report/gpu_clock.py: the warm-up that waits for an idle GPU's clock to rise, and the
clock reader where there is no NVML (this machine: llvmpipe, no NVIDIA driver)."""
from __future__ import annotations

from lift_gl.report.gpu_clock import ClockReader, warm_up


class FakeClock:
    """An SM clock that rises by `rise` MHz with each step of work, from `idle` to `peak`."""

    def __init__(self, idle=345, peak=1980, rise=400):
        self.mhz, self.peak, self.rise = idle, peak, rise

    def step(self):
        self.mhz = min(self.peak, self.mhz + self.rise)

    def sm_mhz(self):
        return self.mhz

    def max_sm_mhz(self):
        return self.peak


def test_warm_up_steps_until_the_clock_reaches_the_target():
    clock = FakeClock()
    out = warm_up(clock.step, clock, target=0.9)
    # 345 -> 745 -> 1145 -> 1545 -> 1945 MHz: the first reading at or above 0.9 x 1980 = 1782
    assert out["steps"] == 4 and out["reached"] is True and out["sm_mhz"] == 1945


def test_warm_up_does_nothing_when_the_clock_is_already_up_and_runs_its_minimum():
    clock = FakeClock(idle=1980)
    assert warm_up(clock.step, clock)["steps"] == 0
    assert warm_up(clock.step, clock, min_steps=3)["steps"] == 3


def test_warm_up_gives_up_after_max_seconds():
    clock = FakeClock(rise=0)          # a clock held down (a power cap, another job)
    ticks = iter(range(100))
    out = warm_up(clock.step, clock, max_seconds=5, now=lambda: next(ticks))
    assert out["reached"] is False and out["steps"] == 4   # started at tick 0; ticks 1-4 are inside 5 s


def test_without_nvml_every_reading_is_none_and_only_the_minimum_runs():
    reader = ClockReader(library="libno-such-nvml.so")
    assert not reader.available
    assert reader.sample() == {"sm_mhz": None, "max_sm_mhz": None} and reader.reasons() is None
    steps = []
    out = warm_up(lambda: steps.append(1), reader, min_steps=2)
    assert len(steps) == 2 and out["reached"] is None


class FakeNVML:
    """NVML's calls as ClockReader makes them (ctypes byref arguments), over two GPUs."""

    NAMES = (b"NVIDIA A100-SXM4-40GB", b"NVIDIA H100 80GB HBM3")
    CLOCKS = ((1410, 1410), (1755, 1980))      # (now, max) per device

    def nvmlInit_v2(self):
        return 0

    def nvmlDeviceGetCount_v2(self, count):
        count._obj.value = len(self.NAMES)
        return 0

    def nvmlDeviceGetHandleByIndex_v2(self, i, handle):
        handle._obj.value = i + 1
        return 0

    def nvmlDeviceGetName(self, handle, buf, size):
        buf.value = self.NAMES[handle.value - 1]
        return 0

    def nvmlDeviceGetClockInfo(self, handle, kind, mhz):
        mhz._obj.value = self.CLOCKS[handle.value - 1][0]
        return 0

    def nvmlDeviceGetMaxClockInfo(self, handle, kind, mhz):
        mhz._obj.value = self.CLOCKS[handle.value - 1][1]
        return 0


def test_the_reader_follows_the_gl_renderer(monkeypatch):
    """The GPU GL renders on is found by name among several; a GL that is not NVIDIA's
    (llvmpipe, an integrated GPU beside an NVIDIA card) gets no readings, so no other GPU's
    clock is read or waited for; no renderer name (a CUDA program): device 0."""
    import lift_gl.report.gpu_clock as gpu_clock

    monkeypatch.setattr(gpu_clock.ctypes, "CDLL", lambda name: FakeNVML())
    h100 = ClockReader("NVIDIA H100 80GB HBM3/PCIe/SSE2")
    assert h100.sample() == {"sm_mhz": 1755, "max_sm_mhz": 1980}
    assert ClockReader().sample() == {"sm_mhz": 1410, "max_sm_mhz": 1410}
    other = ClockReader("llvmpipe (LLVM 15.0.6, 256 bits)")
    assert not other.available and other.sample() == {"sm_mhz": None, "max_sm_mhz": None}


def test_bench_records_the_clock_field(tmp_path):
    """lift-gl bench's JSON carries sm_clock (readings None here), and its line says nothing
    of a clock it could not read."""
    from lift_gl.report.bench import bench_case, clock_note
    from lift_gl.scene.loader import load_scene
    from conftest import REPO

    case = bench_case(load_scene(REPO / "scenes" / "cornell.toml"), (32, 32), frames=2, repeat=1, denoisers=())
    clock = case["sm_clock"]
    assert len(clock["frames_mhz"]) == 1 and clock["warm_up"]["steps"] >= 0
    if not ClockReader().available:
        assert clock_note(case) == ""
    assert clock_note({"sm_clock": {"frames_mhz": [1755, 1980], "warm_up": {"max_sm_mhz": 1980}}}) == \
        ", SM clock 1755 MHz (max 1980)"

