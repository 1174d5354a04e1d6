"""The waves at the largest grid the model accepts, on a Vulkan device against the CPU.

llvmpipe (lavapipe) caps the iterations of a loop in one device thread at 65,535, so a part
that walks the whole grid on one thread (the absorbing layer once did, and the refresh after
the host sets the surface) leaves the last cells of a 65,536-cell grid untouched. Every grid
loop is parallel now; this runs a few steps of such a grid on both backends (each in a child
process, as ``tests/test_device.py`` runs its devices) and holds the surface and the absorbed
energy to the device tolerance (docs/devices.md).
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from melange_ti.physics.effects.waves import MAX_CELLS

from .test_device import needs_vulkan

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 1e-12  # as tests/test_device.py's f64 runs: relative to the largest |eta|

# one iceberg off its equilibrium in a sea lifted 0.01 w everywhere (the last 50 w an
# absorbing layer), three steps; wave_dx 0.01 over 400 w makes the largest grid, whose
# shortest waves need a wave step of one time step (wave_dt = dt)
CHILD = """
import sys
import numpy as np
from melange_ti import runtime
runtime.init(sys.argv[1], precision="f64")
from melange_ti.model import Model
from melange_ti.scene import loads
text = ('[scene]\\neffects = ["gravity", "buoyancy", "waves"]\\n'
        '[physics]\\nwave_end = 400.0\\nwave_sponge = 50.0\\nwave_dx = 0.01\\nwave_dt = 0.02\\n'
        '[time]\\ndt = 0.02\\nduration = 0.06\\n[[iceberg]]\\nx = 100.0\\nz = -0.3\\n')
m = Model(loads(text))
m.effect("waves").set_surface(np.full(m.effect("waves").cells, 0.01))
m.advance(3)
s, totals = m.sample_with_totals()
g = m.effect("waves")
np.savez(sys.argv[2], eta=g.surface()["eta"], z=s["z"], absorbed=totals.wave_absorbed, cells=g.cells)
"""


def _run(arch: str, out: Path) -> dict:
    subprocess.run([sys.executable, "-c", CHILD, arch, str(out)], check=True, capture_output=True, cwd=ROOT, timeout=900)
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


@pytest.mark.gpu
@needs_vulkan
def test_largest_wave_grid_on_vulkan_matches_the_cpu(tmp_path):
    cpu = _run("cpu", tmp_path / "cpu.npz")
    dev = _run("vulkan", tmp_path / "vulkan.npz")
    assert int(cpu["cells"]) == int(dev["cells"]) == MAX_CELLS
    eta, eta_dev = cpu["eta"], dev["eta"]
    assert eta[-1] < 0.0099  # the layer damped the last cell (at the rate 0.5: by 3%)
    assert float(np.ptp(eta[: len(eta) // 2])) > 1e-6  # and the iceberg (at x = 100) moved the water
    scale = float(np.max(np.abs(eta)))
    assert float(np.max(np.abs(eta_dev - eta))) / scale <= TOLERANCE
    assert abs(float(dev["absorbed"]) - float(cpu["absorbed"])) <= TOLERANCE * float(cpu["absorbed"])
    assert abs(float(dev["z"][0]) - float(cpu["z"][0])) <= TOLERANCE
