"""Which device ``--arch`` takes, and Ctrl-C on a slow one (issue 32, point 9).

A Vulkan device of type CPU (Mesa's lavapipe, the only one on the build machine) is a CPU
posing as a GPU: ``--arch gpu`` refuses it as it refuses a machine without a GPU, an explicit
``--arch vulkan`` runs on it with a note. A run's launches are capped by the pace measured on
the launch before, so an interrupt acts within about a second on any backend, with the same
bits as launches of any other length.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

from melange_ti import cli, probe, runtime, simulation
from melange_ti.errors import ArchError, Interrupted
from melange_ti.model import Model
from melange_ti.scene import loads
from melange_ti.simulation import Simulation

from .test_ensemble import TINY

ROOT = Path(__file__).resolve().parents[1]
SOFTWARE = [d for d in probe.vulkan_devices() if d[0] == "cpu"]
needs_software_vulkan = pytest.mark.skipif(not SOFTWARE, reason="no software Vulkan device (lavapipe) here")


# ---------------------------------------------------------------------------- the device's type
def test_the_device_taichi_takes(monkeypatch):
    """Taichi 1.7's choice (its get_device_score): a GPU over lavapipe, a discrete GPU over an
    integrated one, the first of equal scores, TI_VISIBLE_DEVICE when it names a device."""
    monkeypatch.delenv("TI_VISIBLE_DEVICE", raising=False)
    lavapipe, igpu, dgpu = ("cpu", "llvmpipe", 1400), ("integrated", "Intel", 1600), ("discrete", "NVIDIA", 2300)
    for devices, want in (
        ([lavapipe], lavapipe),
        ([lavapipe, igpu], igpu),
        ([igpu, lavapipe, dgpu], dgpu),
        ([("cpu", "a", 1400), ("cpu", "b", 1400)], ("cpu", "a", 1400)),
        ([], None),
    ):
        monkeypatch.setattr(probe, "vulkan_devices", lambda d=devices: d)
        assert probe.vulkan_device() == (want[:2] if want else None)
    monkeypatch.setattr(probe, "vulkan_devices", lambda: [dgpu, lavapipe])
    monkeypatch.setenv("TI_VISIBLE_DEVICE", "1")
    assert probe.vulkan_device() == lavapipe[:2]
    monkeypatch.setenv("TI_VISIBLE_DEVICE", "7")  # no such device: Taichi ignores it
    assert probe.vulkan_device() == dgpu[:2]


@needs_software_vulkan
def test_lavapipe_is_read_as_a_cpu():
    kind, name = probe.vulkan_device()
    assert kind == "cpu" and "llvmpipe" in name


@pytest.mark.gpu
@needs_software_vulkan
def test_gpu_skips_a_software_device_and_vulkan_takes_it(tmp_path, capsys):
    """``--arch gpu`` with lavapipe the only Vulkan device: one line, status 2, no file, as
    where there is no GPU. ``--arch vulkan``: it runs, with a one-line note."""
    with pytest.raises(ArchError) as refused:
        runtime.probe("gpu", "f64")
    line = str(refused.value)
    assert line.startswith("--arch gpu: no GPU on this machine") and SOFTWARE[0][1] in line and "use --arch cpu" in line
    out = tmp_path / "run.h5"
    assert cli.main(["run", "--arch", "gpu", "--set", "shelf.count=4", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0] == f"melange-ti: error: {line}", err
    assert not out.exists()

    assert runtime.probe("vulkan", "f64") == "vulkan" and runtime.software_device("vulkan") == SOFTWARE[0][1]
    cmd = [sys.executable, "-m", "melange_ti", "run", "--arch", "vulkan", "--set", "shelf.count=4"]
    cmd += ["--set", "time.duration=0.05", "--out", str(out)]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path, timeout=900)
    assert p.returncode == 0, p.stderr
    notes = [ln for ln in p.stderr.splitlines() if ln.startswith("melange-ti: note:")]
    assert notes == [f"melange-ti: note: --arch vulkan: {SOFTWARE[0][1]} is a software device (a CPU posing as a GPU), "
                     "slower than --arch cpu"], p.stderr  # fmt: skip
    with h5py.File(out, "r") as f:
        assert f.attrs["arch"] == "vulkan"


# ---------------------------------------------------------------------------- launches and Ctrl-C
def _datasets(path: Path) -> dict[str, bytes]:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o[()].tobytes()) if isinstance(o, h5py.Dataset) else None)
    return out


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The tiny scene run as it is (launches of many events), in each kernel form."""
    folder = tmp_path_factory.mktemp("launches")
    return {mode: Simulation(loads(TINY), folder / f"{mode}.h5", progress=False, mode=mode).run().path for mode in MODES}


MODES = ("serial", "parallel")


@pytest.mark.parametrize("mode", MODES)
def test_one_step_launches_keep_the_bits(tmp_path, monkeypatch, reference, mode):
    """Every launch capped to one step (the cap of a device doing a step in half a second):
    every dataset bit for bit as the run in launches of many events."""
    monkeypatch.setattr(simulation, "CHECK_SECONDS", 0.0)
    launches = []
    original = Model.advance

    def counted(self, steps):
        launches.append(steps)
        return original(self, steps)

    monkeypatch.setattr(Model, "advance", counted)
    out = Simulation(loads(TINY), tmp_path / "capped.h5", progress=False, mode=mode).run().path
    # after the first two launches (two events each in the serial form) one step at a time
    assert set(launches) == {1} and len(launches) >= 300, launches
    assert _datasets(out) == _datasets(reference[mode])


class _FakeInterrupt:
    """Ctrl-C pressed ``after`` seconds into the run (no real signal in the test process)."""

    after = 1.0

    def __init__(self):
        self.at = time.perf_counter() + self.after
        self.seen = None

    @property
    def requested(self) -> bool:
        if time.perf_counter() >= self.at and self.seen is None:
            self.seen = time.perf_counter()
        return self.seen is not None

    def restore(self):
        _FakeInterrupt.last = self


# diagnostics every 50 steps, a checkpoint every 250, one snapshot at each end: before, a
# launch ran the 250 steps from one checkpoint to the next
SPARSE = TINY.replace("snapshot_interval = 1.0", "snapshot_interval = 5.0").replace(
    "checkpoint_interval = 1.0", "checkpoint_interval = 2.5"
)


@pytest.mark.parametrize("mode", MODES)
def test_interrupt_acts_within_a_second_on_a_slow_backend(tmp_path, monkeypatch, mode):
    """Stepping slowed to 100 steps/s (a slow device's pace): a launch of five diagnostics
    took 2.5 s before, and Ctrl-C at 3 s waited for the end of the run. It now stops the
    run within a second, at a step that need not be an output event, and the run resumed
    from there is bit-identical to an uninterrupted one."""
    whole = Simulation(loads(SPARSE), tmp_path / "whole.h5", progress=False, mode=mode).run().path
    per_step = 1 / 100
    real_advance, real_sampled = Model.advance, Model.advance_sampled
    inside = []

    def slow_advance(self, steps):
        if not inside:
            time.sleep(steps * per_step)
        return real_advance(self, steps)

    def slow_sampled(self, segments, light=()):
        time.sleep(sum(segments) * per_step)
        inside.append(1)
        try:
            return real_sampled(self, segments, light)
        finally:
            inside.pop()

    monkeypatch.setattr(Model, "advance", slow_advance)
    monkeypatch.setattr(Model, "advance_sampled", slow_sampled)
    monkeypatch.setattr(_FakeInterrupt, "after", 3.0)
    monkeypatch.setattr(simulation, "_DeferredInterrupt", _FakeInterrupt)
    out = tmp_path / "stopped.h5"
    with pytest.raises(Interrupted) as stopped:
        Simulation(loads(SPARSE), out, progress=False, mode=mode).run()
    late = _FakeInterrupt.last.seen - _FakeInterrupt.last.at
    assert late < 1.0, late
    assert "of 500" in str(stopped.value), stopped.value  # the message: "(step N of 500)"
    monkeypatch.undo()
    Simulation(loads(SPARSE), out, resume=True, progress=False, mode=mode).run()
    assert _datasets(out) == _datasets(whole)
