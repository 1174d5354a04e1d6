"""docs/architecture.md against the code, where it can drift: the rooms of physics/, the files
it names, and the promise that nothing outside an effect that owns state names it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import melange_ti
from melange_ti.physics.effects import OWNERS, REGISTRY

PACKAGE = Path(melange_ti.__file__).resolve().parent
DOC = (PACKAGE.parent / "docs" / "architecture.md").read_text()

# the layers that take everything of an effect from its declaration
GENERIC = ("model.py", "simulation.py", "io/hdf5.py", "io/checkpoint.py", "api.py", "scene/core.py", "physics/step/stages.py")


def _rooms() -> dict[str, set[str]]:
    """The physics/ listing in the doc: ``{room: files}`` (a room ``numerics.py`` is a file)."""
    block = DOC.split("```\nphysics/\n", 1)[1].split("```", 1)[0]
    rooms: dict[str, set[str]] = {}
    room = None
    for line in block.splitlines():
        cells = re.split(r"\s{2,}", line.strip())  # the listing's columns: room, files, meaning
        if line.startswith("  ") and not line.startswith("   "):
            room, cells = cells[0], cells[1:]
            rooms[room] = set()
        files = [t for t in (cells[0].split() if cells else []) if t.endswith((".py", "/"))]
        if room is not None:
            rooms[room] |= set(files)
    return rooms


def test_the_rooms_listed_are_the_folders():
    rooms = _rooms()
    physics = PACKAGE / "physics"
    actual = {
        p.name + ("/" if p.is_dir() else "") for p in physics.iterdir() if p.name != "__pycache__" and p.name != "__init__.py"
    }
    assert set(rooms) == actual
    for room, files in rooms.items():
        if not room.endswith("/"):
            continue
        present = {
            p.name + ("/" if p.is_dir() else "")
            for p in (physics / room).iterdir()
            if p.name not in ("__pycache__", "__init__.py")
        }
        listed = {f for f in files if f != "NAME.py"}
        assert listed <= present, (room, listed - present)
        if room != "effects/":  # the effects' declarations are listed as NAME.py
            assert present == listed, (room, present ^ listed)


def test_every_module_path_the_doc_names_exists():
    paths = {p for p in re.findall(r"`((?:physics|io|scene|analysis|effects|forms|step)/[\w/]+\.py)`", DOC) if "NAME" not in p}
    assert len(paths) > 10
    missing = []
    for path in paths:
        candidates = [PACKAGE / path, PACKAGE / "physics" / path, PACKAGE / "physics" / "step" / path]
        if not any(c.exists() for c in candidates):
            missing.append(path)
    assert not missing, missing


def test_the_rooms_parser_reads_the_listing():
    rooms = _rooms()
    assert rooms["step/"] >= {"stages.py", "impulses.py", "correction.py"} and "numerics.py" in rooms


@pytest.mark.parametrize("effect", OWNERS, ids=lambda e: e.name)
def test_an_effect_that_owns_state_is_a_package_of_the_files_the_doc_lists(effect):
    package = PACKAGE / "physics" / "effects" / effect.name
    for name in ("__init__.py", "host.py", "kernels.py"):
        assert f"`{name}`" in DOC and (package / name).exists(), name
    # the declaration reaches both by a real import
    assert effect.state is not None and effect.kernels is not None
    assert effect.kernels().__file__ == str(package / "kernels.py")
    assert hasattr(effect.kernels(), "STAGES")


@pytest.mark.parametrize("path", GENERIC)
def test_the_generic_layers_name_no_effect_that_owns_state(path):
    """The model, the run loop, the file, the API, the scene's checks and the step take an
    owning effect from its declaration: none of them names one (not in a comment either)."""
    text = (PACKAGE / path).read_text().lower()
    assert len(OWNERS) >= 1
    for effect in OWNERS:
        stem = effect.name.rstrip("s")  # "waves" -> "wave": wave_energy, wave_x, ...
        assert stem not in text, f"{path} names {effect.name!r}"


def test_terms_are_imported_by_name_not_by_a_string():
    base = (PACKAGE / "physics" / "effects" / "base.py").read_text()
    assert "importlib" not in base
    for effect in REGISTRY:
        if effect.terms:
            module = effect.kernels()
            for term in effect.terms:
                assert callable(getattr(module, term)), (effect.name, term)


def test_columns_import_alone():
    """physics/data/columns.py holds the types only: importing it alone gives what it
    promises, with no namespace half filled."""
    import subprocess
    import sys

    code = "import melange_ti.physics.data.columns as c; print(sorted(n for n in vars(c) if n[0].isupper()))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "Body" not in out and "Column" in out and "Table" in out


def test_a_declaration_that_the_writer_could_not_follow_is_refused():
    """A dataset over no dimension, over one the effect does not declare, or over the icebergs'
    alone by an effect that declares none, would be written in runs that do not name the
    effect, or never; ledgers of the contact law need its impulse."""
    from melange_ti.physics.data.columns import Column
    from melange_ti.physics.effects.base import Dataset, Effect

    cell = (("cell", "a cell"),)
    ok = Effect(name="trial", doc="", dims=cell, datasets=(Dataset("snapshots/h", ("cell",), "w", "h"),))
    assert ok.datasets[0].name == "h" and ok.datasets[0].group == "snapshots"
    with pytest.raises(ValueError, match="dimensions it declares"):
        Effect(name="trial", doc="", dims=cell, datasets=(Dataset("snapshots/h", (), "w", "h"),))
    with pytest.raises(ValueError, match="dimensions it declares"):
        Effect(name="trial", doc="", datasets=(Dataset("snapshots/h", ("iceberg",), "w", "h"),))
    with pytest.raises(ValueError, match="dimensions it declares"):
        Effect(name="trial", doc="", dims=cell, datasets=(Dataset("snapshots/h", ("other",), "w", "h"),))
    per_berg = Effect(name="trial", doc="", dims=cell, datasets=(Dataset("snapshots/h", ("iceberg",), "w", "h"),))
    assert per_berg.datasets[0].dims == ("iceberg",)
    ledger = Column("TRIAL", "ledger", "rho_w g w^3", "a trial ledger", "trial_work", budget=True)
    with pytest.raises(ValueError, match="impulse"):
        Effect(name="trial", doc="", law_ledgers=(ledger,))


def test_a_scene_naming_an_owning_effect_twice_is_not_refused_as_two_owners():
    from melange_ti.scene import load

    for effect in OWNERS:
        scene = load(None, [("scene.effects", ["gravity", "buoyancy", effect.name, effect.name])])
        assert getattr(scene.effects, effect.name)
