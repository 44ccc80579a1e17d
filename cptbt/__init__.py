"""cptbt: a behaviour-tree Adaptive Mission Planner for chemical plume tracing AUVs.

The core (this package) holds the value types, perception, behaviour registry, mission schema,
tree builder and planner facade. Behaviours live in :mod:`cptbt.behaviours` and the simulator in
:mod:`cptbt.sim`; the core imports neither.
"""

from pathlib import Path

from cptbt.loader import MissionError, dump_mission, load_mission
from cptbt.planner import Planner
from cptbt.types import Command, Percept, Point, Pose

# Run from a source checkout (``python -m cptbt``, ``python -m pytest`` in the repository root),
# this folder shadows the installed package, and ``behaviours/`` and ``sim/`` sit beside it
# instead of inside it (pyproject.toml's package-dir mapping). Let the package find them there,
# so the checkout behaves exactly as the install does.
_checkout = Path(__file__).resolve().parent.parent
if (_checkout / "pyproject.toml").is_file() and not (Path(__file__).parent / "sim").is_dir():
    __path__.append(str(_checkout))

__version__ = "0.2.0"

__all__ = [
    "Command",
    "MissionError",
    "Percept",
    "Planner",
    "Point",
    "Pose",
    "__version__",
    "dump_mission",
    "load_mission",
]
