"""What the report ran on: package versions and the machine, with its load at the time."""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

#: Packages whose versions the numbers depend on.
VERSIONED = ("torch", "torchrl", "tensordict", "pymunk", "pettingzoo", "numpy")


def versions() -> list[str]:
    """``name version`` of python and of :data:`VERSIONED`."""
    found = [f"python {platform.python_version()}"]
    for name in VERSIONED:
        try:
            found.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            found.append(f"{name} (not installed)")
    return found


def machine() -> list[str]:
    """The OS, CPU count and model, and ``uptime`` (the load tells how busy the CPUs were)."""
    model = "unknown CPU"
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    try:
        uptime = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        uptime = "unavailable"
    return [
        f"{platform.system()} {platform.release()}, {os.cpu_count()} CPUs ({model})",
        f"`uptime` when this report was generated: `{uptime}`",
    ]
