"""docs/architecture.md against the code, where it can drift: the rooms of physics/, the files
it names, and the promise that nothing outside an effect that owns state names it."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

import melange_ti
from melange_ti.physics.effects import OWNERS, REGISTRY

PACKAGE = Path(melange_ti.__file__).resolve().parent
DOC = (PACKAGE.parent / "docs" / "architecture.md").read_text()

# the layers that take everything of an effect from its declaration
GENERIC = ("model.py", "simulation.py", "io/hdf5.py", "io/checkpoint.py", "api.py", "scene/core.py", "physics/stages.py")


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
    assert rooms["step/"] >= {"parts.py", "impulses.py", "correction.py"} and "numerics.py" in rooms and "stages.py" in rooms


@pytest.mark.parametrize("effect", OWNERS, ids=lambda e: e.name)
def test_an_effect_that_owns_state_is_a_package_of_the_files_the_doc_lists(effect):
    package = PACKAGE / "physics" / "effects" / effect.name
    for name in ("__init__.py", "host.py", "kernels.py"):
        assert f"`{name}`" in DOC and (package / name).exists(), name
    # linked by a real import from above: the host side in effects/hosts.py, the kernels in step/terms.py
    from melange_ti.physics.effects import hosts
    from melange_ti.physics.step import terms

    assert Path(terms.module(effect).__file__) == package / "kernels.py"
    assert hasattr(terms.module(effect), "STAGES")
    assert Path(sys.modules[hosts.STATES[effect.name].__module__].__file__) == package / "host.py"


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
    from melange_ti.physics.step import impulses, terms

    for path in ("physics/effects/base.py", "physics/step/terms.py", "physics/effects/hosts.py"):
        assert "importlib" not in (PACKAGE / path).read_text()
    for effect in REGISTRY:
        for term in effect.terms:
            module = impulses.LAWS[effect.name] if term == "impulse" else terms.module(effect)
            assert callable(getattr(module, term)), (effect.name, term)
    from melange_ti.physics.data.schema import Body
    from melange_ti.physics.effects import SUBSTEPPED

    for effect in SUBSTEPPED:  # the sub-steps' drift velocities: three distinct columns of the iceberg row
        cols = terms.module(effect).DRIFT_SUM
        assert len(set(cols)) == 3 and all(0 <= c < Body.SIZE for c in cols), (effect.name, cols)
        assert {"pre_drift", "substep_damp", "substep_update"} <= set(effect.terms), effect.name


# ---------------------------------------------------------------- floors: the import graph


def test_the_import_graph_has_no_circle():
    """``python -m melange_ti.imports`` reads every import (inside functions too): none closes a circle."""
    from melange_ti import imports

    edges = imports.graph()
    assert len(edges) > 80 and sum(map(len, edges.values())) > 250  # it read the package
    assert imports.circles(edges) == []


def test_the_import_graph_sees_imports_inside_functions_and_for_type_checking(tmp_path):
    """The reader can fail: a circle closed by an import in a function, under TYPE_CHECKING, or
    through a package's ``__init__`` (importing ``p.q`` runs ``p`` first), is found."""
    from melange_ti import imports

    pkg = tmp_path / "pk"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .b import B\n")
    (pkg / "a.py").write_text("from .sub import b\nX = 1\n")
    (pkg / "sub" / "b.py").write_text("B = 2\n\ndef f():\n    from ..a import X\n    return X\n")
    (pkg / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .d import D\n")
    (pkg / "d.py").write_text("from . import c\nD = 3\n")
    # and one through a package's __init__, which importing its module runs first
    (pkg / "p").mkdir()
    (pkg / "p" / "__init__.py").write_text("from ..e import E\n")
    (pkg / "p" / "q.py").write_text("Q = 4\n")
    (pkg / "e.py").write_text("from .p.q import Q\nE = 5\n")
    found = imports.circles(imports.graph(pkg))
    assert ["pk.a", "pk.sub", "pk.sub.b"] in found and ["pk.c", "pk.d"] in found and ["pk.e", "pk.p"] in found


def test_the_floors_run_one_way():
    """The step's serial phases stand below their parallel and device forms (stages.py, above
    both, puts them together); an effect's declaration imports none of its kernels or host code
    (they are linked from above: step/terms.py, effects/hosts.py); nothing under physics/ reaches
    up into the run files, the scene, the model or the run."""
    from melange_ti import imports

    edges = imports.graph()
    up = ("melange_ti.io", "melange_ti.scene", "melange_ti.model", "melange_ti.simulation", "melange_ti.api")
    for module, targets in edges.items():
        if module.startswith("melange_ti.physics.step."):
            assert not any(t.startswith("melange_ti.physics.forms") for t in targets), module
        if module.startswith("melange_ti.physics"):
            assert not any(t.startswith(up) for t in targets), (module, sorted(t for t in targets if t.startswith(up)))
    declarations = [f"melange_ti.physics.effects.{e.name}" for e in REGISTRY] + ["melange_ti.physics.effects.base"]
    for module in declarations:
        assert module in edges, module
        # the column types, and the data package's __init__ that importing them runs (it imports nothing)
        assert not edges["melange_ti.physics.data"]
        ground = ("melange_ti.physics.effects", "melange_ti.physics.data.columns")
        low = {t for t in edges[module] if not t.startswith(ground) and t != "melange_ti.physics.data"}
        assert not low - {"melange_ti.geometry"}, (module, low)
        assert not any(t.endswith((".host", ".kernels", ".hosts")) or ".terms" in t for t in edges[module]), module


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


# ---------------------------------------------------------------- the choice of form, as data


def _rules(cpu, threads, n, contacts, order="auto", mode="auto"):
    """The choice as Model.__init__ wrote it before the table (its conditions, one by one)."""
    from melange_ti.model import CALIBRATE_MIN_N, ISLANDS_MIN_THREADS, MAX_GROUPS, SERIAL_MAX_N

    coloured = contacts and (order == "coloured" or (order == "auto" and not cpu))
    islands = not cpu or threads >= ISLANDS_MIN_THREADS
    device_parts = not cpu
    grouped = cpu and not islands and not device_parts and not coloured
    groups = max(1, min(threads if cpu else 1, n - 1, MAX_GROUPS)) if grouped else 1
    calibrate = mode == "auto" and cpu and threads > 1 and CALIBRATE_MIN_N <= n <= SERIAL_MAX_N
    if mode == "auto":
        mode = "serial" if cpu and n <= SERIAL_MAX_N else "parallel"
    order = "coloured" if coloured else "sequential"
    return dict(order=order, islands=islands, device_parts=device_parts, groups=groups, mode=mode, calibrate=calibrate)


@pytest.mark.parametrize("order", ["auto", "sequential", "coloured"])
@pytest.mark.parametrize("mode", ["auto", "serial", "parallel"])
def test_the_form_table_gives_the_rules_it_replaced(order, mode):
    import dataclasses

    from melange_ti.model import choose_form

    for cpu, threads in ((True, 1), (True, 2), (True, 3), (True, 4), (True, 16), (False, 0)):
        for n in (1, 2, 3, 100, 1999, 2000, 50_000, 50_001, 1_000_000):
            for contacts in (True, False):
                got = dataclasses.asdict(choose_form(cpu=cpu, threads=threads, n=n, contacts=contacts, order=order, mode=mode))
                assert got == _rules(cpu, threads, n, contacts, order, mode), (cpu, threads, n, contacts)


def test_a_setting_given_to_the_model_overrides_the_table():
    from melange_ti.model import choose_form

    assert choose_form(cpu=True, threads=2, n=10_000, contacts=True, islands=True).islands
    assert choose_form(cpu=True, threads=2, n=10_000, contacts=True, islands=True).groups == 1  # groups need islands off
    assert choose_form(cpu=True, threads=2, n=10_000, contacts=True, groups=5).groups == 5
    assert choose_form(cpu=True, threads=2, n=4, contacts=True, groups=5).groups == 3  # at most n - 1
    assert choose_form(cpu=False, threads=0, n=10, contacts=True, device_parts=False).device_parts is False


def test_two_effects_cannot_declare_one_file_name():
    """Any set of effects may be named together, so no two may write the same dimension or
    dataset (the registry is checked at import; a trial pair here)."""
    from melange_ti.physics.effects import REGISTRY, clashes
    from melange_ti.physics.effects.base import Dataset, Effect

    assert clashes(REGISTRY) == []
    cell = (("cell", "a cell"),)
    one = Effect(name="one", doc="", dims=cell, datasets=(Dataset("snapshots/h", ("cell",), "w", "h"),))
    two = Effect(name="two", doc="", dims=cell, datasets=(Dataset("snapshots/g", ("cell",), "w", "g"),))
    assert clashes((one, two)) == ["cell"]
