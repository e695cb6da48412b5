import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
# Offscreen rendering without a display (MuJoCo reads MUJOCO_GL when it is imported).
if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("MUJOCO_GL", "egl")

#: A small, fast snake for the tests: 5 links, no obstacles.
SMALL = {"snake.n_links": 5, "terrain.kind": "none"}


@pytest.fixture
def small():
    return dict(SMALL)


@pytest.fixture(scope="session")
def ray_local():
    """One local Ray cluster (2 CPUs, loopback only) for the whole test run."""
    ray = pytest.importorskip("ray")
    from simserpent.ray_sweep import init_ray

    init_ray(num_cpus=2)
    yield ray
    ray.shutdown()


def cli():
    """The newest built `simserpent` CLI binary (debug or release), or None."""
    roots = {Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target")), REPO / "target"}
    found = [r / p / "simserpent" for r in roots for p in ("debug", "release")]
    found = [f for f in found if f.is_file()]
    return max(found, key=lambda f: f.stat().st_mtime) if found else None
