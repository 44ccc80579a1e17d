"""cptbt: a behaviour-tree Adaptive Mission Planner for chemical plume tracing AUVs.

The core (this package) holds the value types, perception, behaviour registry, mission schema,
tree builder and planner facade. Behaviours live in :mod:`cptbt.behaviours` and the simulator in
:mod:`cptbt.sim`; the core imports neither.
"""

from cptbt.loader import MissionError, dump_mission, load_mission
from cptbt.planner import Planner
from cptbt.types import Command, Percept, Point, Pose

__version__ = "0.1.0"

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
