"""The machine a timing was measured on, in words: CPU, cores, load, GL device."""
from __future__ import annotations

import os
import platform


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def describe_machine(ctx=None) -> dict:
    """CPU model, cores this process may use, load average, OS, and the GL device."""
    info = {"cpu": cpu_model(), "cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
            "os": platform.platform(terse=True), "python": platform.python_version()}
    try:
        info["load_average"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        pass
    if ctx is not None:
        from ..gl.context import describe

        info["gl"] = describe(ctx)
    return info


def machine_line(info: dict) -> str:
    load = info.get("load_average")
    parts = [f"{info['cores']}-core {info['cpu']}", info["os"]]
    if "gl" in info:
        parts.append(info["gl"])
    if load:
        parts.append(f"load average {load[0]:.1f} at the start")
    return ", ".join(parts)
