"""Shared by the Python benchmark scripts: the checkout, the CPU's name, project-relative paths."""

import os
import pathlib
import platform

ROOT = pathlib.Path(__file__).resolve().parents[1]


def cpu_model():
    for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def project_path(path):
    """A path as the project names it: relative to the checkout (../shared/... for shared data)."""
    return os.path.relpath(pathlib.Path(path).resolve(), ROOT)
