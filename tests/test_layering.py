"""The import layering of src/xlotkit (docs/architecture.md), read from the source with ast.

Every ``import`` and ``from ... import`` in every module is checked, at any depth (a
function-level import is still a dependency). The rules:

* the ground floor (closed forms, units, errors, the record, the log writer, atomic
  writes) imports nothing from ``xlotkit.sim`` or ``xlotkit.interpret``;
* ``xlotkit.sim`` imports nothing from ``xlotkit.interpret`` (the simulator writes its log
  with the ground floor's writer);
* configuration (``xlotkit.sim.scene``, the schedule) imports no engine module;
* the well (``xlotkit.sim.well``: completion, column, choke, drive) and the schedule import
  no configuration or engine above them;
* the model rooms (mesh, mechanics, flow) know nothing of scenes, the well or the engines;
* an engine takes only the contract (``xlotkit.sim.run.contract``) from ``xlotkit.sim.run``
  (the registry builds engines, the engines do not reach back into the driver).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "xlotkit"

#: Modules of the ground floor (dotted names).
GROUND = ("xlotkit.formulas", "xlotkit.units", "xlotkit.errors", "xlotkit.record",
          "xlotkit.logfile", "xlotkit.atomic", "xlotkit.checks")

#: Configuration: the scene model and its validation, the test program.
CONFIGURATION = ("xlotkit.sim.scene", "xlotkit.sim.schedule")

#: Engine modules: the simulators and their drivers (what configuration must not import).
ENGINES = ("xlotkit.sim.lumped", "xlotkit.sim.coupling", "xlotkit.sim.mechanics",
           "xlotkit.sim.flow", "xlotkit.sim.mesh", "xlotkit.sim.run")


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, absolute dotted module) of every import in the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    me = _module_name(path)
    package = me if path.name == "__init__.py" else me.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.append((node.lineno, mod))
            # ``from xlotkit.sim import run`` imports the module xlotkit.sim.run
            out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
    return out


def _within(mod: str, prefixes) -> bool:
    return any(mod == p or mod.startswith(p + ".") for p in prefixes)


def _modules():
    return sorted(PKG.rglob("*.py"))


def _violations(sources, forbidden) -> list[str]:
    bad = []
    for path in _modules():
        name = _module_name(path)
        if not _within(name, sources):
            continue
        seen = set()
        for line, mod in _imports(path):
            if _within(mod, forbidden) and line not in seen:
                seen.add(line)          # one report per import statement
                bad.append(f"{path.relative_to(SRC)}:{line}: {name} imports {mod}")
    return bad


def test_the_tree_has_the_layers_it_is_checked_for():
    names = {_module_name(p) for p in _modules()}
    for mod in (*GROUND, *CONFIGURATION):
        assert mod in names, f"{mod} is not a module any more: update the layering rules"


#: The rooms that may import both halves: the command line, the jobs, the synthetic library
#: and the studies (sweeps simulate and pick; batches read and pick).
ENTRY_POINTS = ("xlotkit.cli", "xlotkit.pipeline", "xlotkit.library", "xlotkit.study")


def test_ground_floor_imports_nothing_from_sim_or_interpret():
    assert _violations(GROUND, ("xlotkit.sim", "xlotkit.interpret", *ENTRY_POINTS)) == []


def test_sim_imports_nothing_from_interpret():
    assert _violations(("xlotkit.sim",), ("xlotkit.interpret", *ENTRY_POINTS)) == []


def test_interpret_imports_nothing_from_sim():
    assert _violations(("xlotkit.interpret",), ("xlotkit.sim", *ENTRY_POINTS)) == []


def test_only_entry_points_import_both_halves():
    # the studies import the jobs; below them, neither half reaches the entry points
    assert _violations(("xlotkit.sim", "xlotkit.interpret"), ENTRY_POINTS) == []
    both = []
    for path in _modules():
        name = _module_name(path)
        mods = [m for _, m in _imports(path)]
        if (any(_within(m, ("xlotkit.sim",)) for m in mods)
                and any(_within(m, ("xlotkit.interpret",)) for m in mods)
                and not _within(name, ENTRY_POINTS)):
            both.append(name)
    assert both == []


def test_configuration_imports_no_engine():
    assert _violations(CONFIGURATION, ENGINES) == []


def test_well_and_schedule_sit_below_configuration():
    assert _violations(("xlotkit.sim.well", "xlotkit.sim.schedule"),
                       ("xlotkit.sim.scene", *ENGINES)) == []


def test_model_rooms_know_nothing_of_scenes_wells_or_engines():
    models = ("xlotkit.sim.mesh", "xlotkit.sim.mechanics", "xlotkit.sim.flow")
    above = ("xlotkit.sim.scene", "xlotkit.sim.schedule", "xlotkit.sim.well",
             "xlotkit.sim.lumped", "xlotkit.sim.coupling", "xlotkit.sim.run",
             "xlotkit.sim.output")
    assert _violations(models, above) == []


def test_engines_take_only_the_contract_from_run():
    engines = ("xlotkit.sim.lumped", "xlotkit.sim.coupling")
    # a statement is reported by the first module it names: the contract module itself for
    # ``from xlotkit.sim.run.contract import X``, xlotkit.sim.run for anything else
    bad = [v for v in _violations(engines, ("xlotkit.sim.run",))
           if not v.endswith("imports xlotkit.sim.run.contract")]
    assert bad == []


@pytest.mark.parametrize("source, forbidden, expect", [
    ("from xlotkit.sim.lumped import LumpedScene\n", ENGINES, 1),
    ("def f():\n    from xlotkit.sim import run\n", ENGINES, 1),
    ("from xlotkit.sim.well import Column\n", ENGINES, 0),
    ("from . import engine\n", ("xlotkit.sim.scene.engine",), 1),
])
def test_the_checker_sees_every_import_form(tmp_path, monkeypatch, source, forbidden, expect):
    # a throw-away module inside a copy of the package layout
    pkg = tmp_path / "xlotkit" / "sim" / "scene"
    pkg.mkdir(parents=True)
    (tmp_path / "xlotkit" / "__init__.py").write_text("")
    (tmp_path / "xlotkit" / "sim" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "probe.py").write_text(source)
    me = sys.modules[__name__]
    monkeypatch.setattr(me, "SRC", tmp_path)
    monkeypatch.setattr(me, "PKG", tmp_path / "xlotkit")
    assert len(_violations(("xlotkit.sim.scene",), forbidden)) == expect


def test_pick_core_loads_methods_by_explicit_import_only():
    """picks/core.py names its methods in code: no importlib, no getattr/hasattr by name,
    no signature probing (house style: no plugin loading by name)."""
    path = PKG / "interpret" / "picks" / "core.py"
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            bad += [(node.lineno, a.name) for a in node.names
                    if a.name.split(".")[0] in ("importlib", "inspect")]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            if (node.module or "").split(".")[0] in ("importlib", "inspect"):
                bad.append((node.lineno, node.module))
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id in ("getattr", "hasattr", "__import__")):
            bad.append((node.lineno, node.func.id))
    assert not bad, f"{path.name}: loading by name at {bad}"


def test_pick_core_registry_covers_every_method():
    """Every shut-in method of shutin.py and every flowback method has one entry."""
    from xlotkit.interpret.picks import core, shutin
    from xlotkit.interpret.picks.flowback import FLOWBACK_METHODS

    fcp = [e.method for e in core.METHODS if e.pick == "FCP"]
    assert fcp == list(shutin.SHUTIN_METHODS) + list(FLOWBACK_METHODS)
    assert [e.phase for e in core.METHODS if e.pick == "FCP"] == (
        ["shut_in"] * len(shutin.SHUTIN_METHODS) + ["flowback"] * len(FLOWBACK_METHODS))
    assert sorted(core.PICK_NAMES) == sorted(("LOP", "FBP", "Pr", "FPP", "ISIP", "FEP"))
    # the step-rate test's fracture-extension pressure (picks/steprate.py) is one entry
    from xlotkit.interpret.picks import steprate

    assert [e.run for e in core.METHODS if e.pick == "FEP"] == [steprate.pick_fep_entry]
