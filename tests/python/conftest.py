"""Fixtures of the Python tests: real meshes from data/ and ../shared/data, and the CLI."""

import os
import pathlib

import numpy as np
import pytest

import splitray

SOURCE = pathlib.Path(os.environ.get("SPLITRAY_SOURCE_DIR", pathlib.Path(__file__).parents[2]))
BINARY = pathlib.Path(os.environ.get("SPLITRAY_BINARY_DIR", SOURCE / "build"))
SHARED = SOURCE.parent / "shared" / "data"


@pytest.fixture(scope="session")
def horse():
    return splitray.load_mesh(SOURCE / "data" / "horse" / "horse.obj.gz")


@pytest.fixture(scope="session")
def cli():
    path = BINARY / "apps" / "splitray" / "splitray"
    if not path.exists():
        pytest.skip(f"the command-line program is not built ({path})")
    return path


def shared_file(relative):
    path = SHARED / relative
    if not path.exists():
        pytest.skip(f"../shared/data is not beside the project ({relative} missing)")
    return path


def rays_at(vertices, n, seed, spread=0.2):
    """Rays from around the mesh towards points near its centre: most hit, some miss."""
    rng = np.random.default_rng(seed)
    lo, hi = vertices.min(0), vertices.max(0)
    centre, size = (lo + hi) / 2, hi - lo
    origins = centre + rng.normal(size=(n, 3)) * size
    targets = centre + rng.normal(size=(n, 3)) * size * spread
    return np.hstack([origins, targets - origins]).astype(np.float32)
