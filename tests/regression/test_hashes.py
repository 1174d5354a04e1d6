"""Every dataset of the regression runs is bit-identical to the hashes recorded at 9cd40e0.

This is the safety net for refactors and optimisations: the default physics may change only
deliberately, by regenerating ``hashes.json`` (``python -m tests.regression.cases --record``)
with the reason in the commit message. Runs go through fresh processes (``f64`` and ``f32``
need their own Taichi runtime)."""

from __future__ import annotations

import json

import pytest

from .cases import CASES, HASHES, dataset_hashes, run_in_subprocesses

STORED = json.loads(HASHES.read_text())
FAST = [n for n, c in CASES.items() if not c[2]]
SLOW = [n for n, c in CASES.items() if c[2]]


def _compare(name, path):
    got = dataset_hashes(path)
    want = STORED[name]
    missing = sorted(set(want) - set(got))
    assert not missing, f"{name}: datasets missing from the file: {missing}"
    changed = sorted(k for k in want if got[k] != want[k])
    assert not changed, f"{name}: datasets whose values changed: {changed}"


@pytest.fixture(scope="module")
def fast_runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("regression")
    run_in_subprocesses(FAST, out)
    return out


def test_every_case_is_recorded():
    assert set(CASES) == set(STORED), "record the new cases: python -m tests.regression.cases --record"


@pytest.mark.parametrize("name", FAST)
def test_short_runs_bit_identical(fast_runs, name):
    _compare(name, fast_runs / f"{name}.h5")


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_long_runs_bit_identical(tmp_path, name):
    run_in_subprocesses([name], tmp_path)
    _compare(name, tmp_path / f"{name}.h5")
