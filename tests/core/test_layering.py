"""The import rules and packaging layout: core ← behaviours, core ← sim, nothing the other way."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import cptbt

CORE = Path(cptbt.__file__).parent
APP_LAYER = ("cli", "batch")  # may compose the simulator and the planner
INSTALLED_UNDER_CORE = ("behaviours", "sim")  # in a non-editable install they sit in cptbt/
FORBIDDEN = ("cptbt.behaviours", "cptbt.sim")


def _core_modules() -> list[Path]:
    return [
        p for p in CORE.rglob("*.py")
        if not p.relative_to(CORE).parts[0].startswith(APP_LAYER + INSTALLED_UNDER_CORE)
        and p.name != "__main__.py"
    ]


def test_core_source_imports_neither_behaviours_nor_sim() -> None:
    offenders = []
    for path in _core_modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [f"{path.name}: {n}" for n in names if n.startswith(FORBIDDEN)]
    assert not offenders
    assert len(_core_modules()) >= 10


def test_importing_the_core_loads_neither_behaviours_nor_sim() -> None:
    modules = sorted(
        "cptbt." + ".".join(p.relative_to(CORE).with_suffix("").parts)
        for p in _core_modules() if p.name != "__init__.py"
    )
    code = (
        "import sys\n"
        + "".join(f"import {m}\n" for m in modules)
        + f"bad = [m for m in sys.modules if m.startswith({FORBIDDEN!r})]\n"
        + "assert not bad, bad\n"
    )
    # Away from the source folder, which would shadow a non-editable install.
    subprocess.run([sys.executable, "-c", code], check=True, cwd=CORE.parents[1])


def test_behaviours_and_sim_install_under_cptbt_only() -> None:
    import cptbt.behaviours
    import cptbt.sim

    assert Path(cptbt.behaviours.__file__).parent.name == "behaviours"
    assert Path(cptbt.sim.__file__).parent.name == "sim"
    # Nothing installs a generic top-level `behaviours` or `sim` (checked away from the source
    # folder, whose own behaviours/ and sim/ folders would otherwise be found first).
    code = (
        "import importlib.util as u\n"
        "assert u.find_spec('behaviours') is None, u.find_spec('behaviours')\n"
        "assert u.find_spec('sim') is None, u.find_spec('sim')\n"
        "import cptbt.behaviours.find_plume, cptbt.sim.world\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=CORE.parents[1])


def test_inspection_commands_work_on_every_shipped_mission_without_the_simulator() -> None:
    # The planner's commands never need simulator truth: with cptbt.sim made unimportable,
    # validate, tree, behaviours and schema still work on every shipped mission.
    missions = sorted(str(p) for p in (CORE.parents[0] / "missions").glob("*.yaml"))
    if not missions:  # a non-editable install: the missions sit beside the tests
        missions = sorted(str(p) for p in (Path(__file__).parents[2] / "missions").glob("*.yaml"))
    assert missions
    code = (
        "import sys\n"
        "sys.modules['cptbt.sim'] = None  # any import of the simulator now fails\n"
        "from cptbt.cli import main\n"
        f"for m in {missions!r}:\n"
        "    assert main(['validate', m]) == 0, m\n"
        "    assert main(['tree', m]) == 0, m\n"
        "assert main(['behaviours']) == 0\n"
        "assert main(['schema']) == 0\n"
        "assert 'cptbt.sim.world' not in sys.modules\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=CORE.parents[1])
    assert res.returncode == 0, res.stderr[-2000:]
    assert "Traceback" not in res.stderr
