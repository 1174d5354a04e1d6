"""Reading run files needs neither Taichi nor the files a run began from.

Analysing runs on a laptop without Taichi must work (the reading path: io.hdf5, the scene,
the diagnostics table and the figures import no Taichi), and a run begun from another
file's snapshot (``[start]``) is plotted and resumed from its own file after that one moved.
"""

from __future__ import annotations

import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from melange_ti import cli, scene
from melange_ti.io.checkpoint import checkpoint_path
from melange_ti.simulation import Simulation

SECTIONS = {
    "scene": {"name": "reading", "effects": ["gravity", "buoyancy", "drag", "collisions", "wall"]},
    "contacts": {"discs": 12},
    "time": {"dt": 0.01, "duration": 2.0, "seed": 3},
    "output": {"snapshot_interval": 0.5, "diagnostic_interval": 0.1, "checkpoint_interval": 1.0},
}
SHELF = {"count": 4, "width": 1.0, "thickness": 1.4, "gap": 0.1, "tilt": 0.01}
THREADS = os.environ.get("MELANGE_TEST_THREADS", "2")  # the session's: --threads would re-initialise Taichi otherwise


class _Stop(Exception):
    pass


def _run(text: str, where, out, stop_at: int | None = None):
    path = where / f"{out}.toml"
    path.write_text(text)

    def stop(step):
        if step == stop_at:
            raise _Stop

    sim = Simulation(scene.load(path), where / f"{out}.h5", progress=False, on_event=stop)
    if stop_at is None:
        sim.run()
    else:
        with pytest.raises(_Stop):
            sim.run()
    return where / f"{out}.h5"


NO_TAICHI = """
import sys

class NoTaichi:
    def find_spec(self, name, path=None, target=None):
        if name == "taichi" or name.startswith("taichi."):
            raise ModuleNotFoundError("No module named 'taichi' (blocked by the test)")

sys.meta_path.insert(0, NoTaichi())
path, figures = sys.argv[1], sys.argv[2]
import melange_ti as mt
from melange_ti import cli, diagnostics
from melange_ti.io.hdf5 import read_run
from melange_ti.scene import stored_scene

data = read_run(path)
assert stored_scene(path, data).shelf.count == 4
with mt.open_run(path) as tree:
    assert tree["diagnostics"]["capsized_fraction"].size == data["diagnostics"]["time"].size
assert cli.main(["plot", path, "--out", figures]) == 0
assert cli.main(["render", path, "--out", figures + "_frames"]) == 0
assert "taichi" not in sys.modules, "Taichi was imported"
print("read without Taichi")
"""


def test_reading_and_plotting_import_no_taichi(tmp_path):
    run = _run(scene.dumps_toml({**SECTIONS, "shelf": SHELF}), tmp_path, "a")
    proc = subprocess.run(
        [sys.executable, "-c", NO_TAICHI, str(run), str(tmp_path / "figures")], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    assert "read without Taichi" in proc.stdout
    assert any((tmp_path / "figures").glob("*.png")) and any((tmp_path / "figures_frames").glob("*.png"))


def test_run_begun_from_another_file_survives_moving_it(tmp_path):
    first = _run(scene.dumps_toml({**SECTIONS, "shelf": SHELF}), tmp_path, "first")
    text = scene.dumps_toml({**SECTIONS, "start": {"file": first.name, "time": 2.0}})
    reference = _run(text, tmp_path, "reference")
    cut = _run(text, tmp_path, "cut", stop_at=150)  # a checkpoint at step 100, then stopped
    assert checkpoint_path(cut).exists()
    first.rename(tmp_path / "moved.h5")

    assert cli.main(["plot", str(cut), "--out", str(tmp_path / "figures")]) == 0
    assert cli.main(["run", "--resume", "--out", str(cut), "--threads", THREADS]) == 0
    with h5py.File(reference, "r") as fr, h5py.File(cut, "r") as fc:
        for group in ("icebergs", "snapshots", "diagnostics"):
            for name in fr[group]:
                assert np.array_equal(fr[group][name][:], fc[group][name][:]), f"{group}/{name}"
        assert bool(fc.attrs["complete"])


# ---------------------------------------------------------------- older formats
def test_every_diagnostic_is_written_and_none_claims_a_future_format(tmp_path):
    from melange_ti import diagnostics
    from melange_ti.io.hdf5 import FORMAT_VERSION, read_run

    run = _run(scene.dumps_toml({**SECTIONS, "shelf": SHELF}), tmp_path, "a")
    data = read_run(run)
    assert data["attrs"]["format_version"] == FORMAT_VERSION
    sc = scene.loads(scene.dumps_toml({**SECTIONS, "shelf": SHELF}))
    assert set(data["diagnostics"]) == {"time", *(f.name for f in diagnostics.fields(sc.effects))}
    assert all(1 <= f.since <= FORMAT_VERSION for f in diagnostics.FIELDS)
    assert diagnostics.required(FORMAT_VERSION) == ("time", *diagnostics.NAMES)
    assert diagnostics.required(FORMAT_VERSION, sc.effects) == ("time", *(f.name for f in diagnostics.fields(sc.effects)))


def test_a_run_holds_the_diagnostics_of_the_effects_it_names(tmp_path):
    """Issue 47: a run without bonds, waves, friction or added mass wrote their diagnostics as
    zeros (10 datasets). A run now holds the model's own diagnostics and those of the effects
    its scene names, and reading, `open_run` and `plot` do without the others; a scene naming
    friction holds friction_dissipated. The paper's own (SPEC: drag and collisions' ledgers
    among them) are in every run."""
    import melange_ti as mt
    from melange_ti import diagnostics
    from melange_ti.io.hdf5 import read_run

    paper = _run(scene.dumps_toml({**SECTIONS, "shelf": SHELF}), tmp_path, "paper")
    rough = {**SECTIONS, "scene": {**SECTIONS["scene"], "effects": [*SECTIONS["scene"]["effects"], "friction"]}}
    friction = _run(scene.dumps_toml({**rough, "shelf": SHELF}), tmp_path, "rough")
    held = {p: set(read_run(p)["diagnostics"]) for p in (paper, friction)}
    owned = {f.name: f.owner for f in diagnostics.FIELDS}
    assert not {n for n in held[paper] if owned.get(n)}, "a paper run holds no effect's diagnostics"
    for name in ("bond_energy", "wave_energy", "wave_absorbed", "fragments", "friction_dissipated", "added_mass_work"):
        assert name not in held[paper]
    assert {"drag_dissipated", "collision_dissipated", "correction_work", "impulse_offset_work"} <= held[paper]
    assert held[friction] - held[paper] == {"friction_dissipated"}
    with mt.open_run(paper) as tree:
        assert "bond_energy" not in tree["diagnostics"] and "kinetic_energy" in tree["diagnostics"]
    assert cli.main(["plot", str(paper), str(friction), "--out", str(tmp_path / "figs")]) == 0


def test_plot_reads_files_older_than_each_diagnostic(tmp_path):
    """A file of each older format (lacking every diagnostic that appeared after it) still
    plots; a file of the format before a diagnostic appeared reads without it, and a file of
    the current format that lacks it is refused in one line."""
    import shutil

    from melange_ti import diagnostics
    from melange_ti.analysis.runs import load_run

    run = _run(scene.dumps_toml({**SECTIONS, "shelf": SHELF}), tmp_path, "a")
    with h5py.File(run, "r") as h:
        held = set(h["diagnostics"])
    newer = [f for f in diagnostics.FIELDS if f.since > 1]
    assert {"impulse_offset_work", "contacts"} <= {f.name for f in newer}
    for version in sorted({f.since - 1 for f in newer}):
        old = tmp_path / f"format_{version}.h5"
        shutil.copy(run, old)
        with h5py.File(old, "r+") as h:
            for f in newer:
                if f.since > version and f.name in held:
                    del h["diagnostics"][f.name]
            # before format 7 every diagnostic was in every file (0 for an effect not named)
            n = h["diagnostics"]["time"].shape[0]
            for f in diagnostics.FIELDS:
                if f.since <= version and f.name not in held and version < diagnostics.OWN_DIAGNOSTICS_SINCE:
                    h["diagnostics"].create_dataset(f.name, data=np.zeros(n, dtype=f.dtype))
            h.attrs["format_version"] = version
        assert cli.main(["plot", str(old), "--out", str(tmp_path / f"figures_{version}")]) == 0, version
    for f in [f for f in newer if f.name in held]:
        old = tmp_path / f"without_{f.name}.h5"
        shutil.copy(run, old)
        with h5py.File(old, "r+") as h:
            del h["diagnostics"][f.name]
            h.attrs["format_version"] = f.since - 1
        assert f.name not in load_run(old).data["diagnostics"], f.name
        with h5py.File(old, "r+") as h:  # a format that holds it (and holds only the named effects')
            h.attrs["format_version"] = max(f.since, diagnostics.OWN_DIAGNOSTICS_SINCE)
        with pytest.raises(Exception, match=f"missing {f.name}"):
            load_run(old)


def test_every_name_xarray_shadows_is_documented(tmp_path):
    """Issue 47: ``tree["icebergs"].width`` is DataTree's own ``width`` (an integer), not the
    variable. Every name the file can hold (any effect's, polygons' included) is checked
    against the attributes of xarray's DataTree and Dataset as installed; the shadowed ones
    must be exactly those documented (``api.XARRAY_SHADOWED``: docs/output.md and the README
    name each, with the item form that works), and on a real file the item form gives the
    variable where attribute access does not."""
    import xarray as xr

    import melange_ti as mt
    from melange_ti.api import XARRAY_SHADOWED
    from melange_ti.io.hdf5 import DIMS, variable_attrs

    from .conftest import ROOT

    names = [f"{group}/{name}" for group, variables in variable_attrs().items() for name in variables] + list(DIMS)
    shadowed = {n for n in names if any(hasattr(kind, n.rsplit("/", 1)[-1]) for kind in (xr.DataTree, xr.Dataset))}
    assert shadowed == set(XARRAY_SHADOWED), "document every shadowed name in api.XARRAY_SHADOWED"
    output_md, readme = (ROOT / "docs" / "output.md").read_text(), (ROOT / "README.md").read_text()
    for name in XARRAY_SHADOWED:
        group, var = name.split("/")
        assert f"`/{name}`" in output_md and f"['{group}']['{var}']" in output_md
        assert f'["{group}"]["{var}"]' in readme, "the README, where a user reads first, shows the item form"
    path = tmp_path / "r.h5"
    mt.run(mt.load_scene(overrides={"shelf.count": 3, "time.duration": 1.0}), path)
    with mt.open_run(path) as tree:
        for name in XARRAY_SHADOWED:
            group, var = name.split("/")
            assert isinstance(tree[group][var], xr.DataArray) and tree[group][var].size == 3
            assert not isinstance(getattr(tree[group], var), xr.DataArray)
