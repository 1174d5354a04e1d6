"""One Taichi runtime per test session (CPU, f64); fields are created inside tests."""

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "runs"


@pytest.fixture(scope="session", autouse=True)
def taichi_cpu():
    from melange_ti import runtime

    runtime.init("cpu", threads=int(os.environ.get("MELANGE_TEST_THREADS", "2")), precision="f64")
    yield


@pytest.fixture
def scene_text():
    """Build a small scene's TOML text from sections given as dicts."""
    from melange_ti.scene import dumps_toml

    def make(**sections) -> str:
        return dumps_toml(sections)

    return make


# The longest test file first: with the files shared out over two processes
# (``-n 2 --dist loadfile``, pyproject.toml) the device tests, ~30% of a cold run, start at
# once in one process while the other takes the rest, instead of running alone at the end.
FIRST = ("tests/test_device.py",)


def pytest_collection_modifyitems(config, items):
    items.sort(key=lambda item: 0 if item.nodeid.startswith(FIRST) else 1)  # stable: order within a file kept
