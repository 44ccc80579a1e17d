"""Building the arbitration tree of TRO Fig. 2 from a mission's behaviour list (SPEC §3).

The tree is ``Sequence(memory=False)[watch:*, Selector(memory=False)[behaviours...]]``:

- the watchers run every cycle the perceptual half of behaviours that need it (declare-source
  keeps checking the lost-contact list even while safety drives) and always succeed;
- the memory-less selector ticks the behaviours in priority order each cycle and stops at the
  first with an output (RUNNING); a behaviour with no output returns FAILURE and the next one is
  tried. When a higher behaviour gets an output, py_trees stops the lower one that was running
  (``terminate(INVALID)``), so it starts afresh (``initialise``) the next time it runs. This is
  exactly the inhibition of the subsumption network: the highest behaviour with a value wins.
"""

from __future__ import annotations

from collections.abc import Iterable

import py_trees

from cptbt.mission import BehaviourEntry
from cptbt.node import PlanBehaviour, Watch, overrides_watch
from cptbt.registry import Registry


def plan_leaves(root: py_trees.behaviour.Behaviour) -> list[PlanBehaviour]:
    """Every :class:`PlanBehaviour` in a tree, in tick order."""
    return [n for n in root.iterate() if isinstance(n, PlanBehaviour)]


def build_tree(
    entries: Iterable[BehaviourEntry], registry: Registry, namespace: str = "/"
) -> py_trees.composites.Sequence:
    """The root of the arbitration tree for a behaviour list (highest priority first)."""
    nodes = [registry.get(e.family, e.variant).build(e.params, namespace) for e in entries]
    arbitrate = py_trees.composites.Selector("subsumption", memory=False, children=nodes)
    watchers: list[py_trees.behaviour.Behaviour] = [
        Watch(leaf) for leaf in plan_leaves(arbitrate) if overrides_watch(type(leaf))
    ]
    return py_trees.composites.Sequence("amp", memory=False, children=[*watchers, arbitrate])


def render_ascii(root: py_trees.behaviour.Behaviour) -> str:
    """The tree as text, with py_trees' symbols for selectors and sequences."""
    return py_trees.display.unicode_tree(root)


def render_dot(root: py_trees.behaviour.Behaviour) -> str:
    """The tree in Graphviz dot."""
    lines = ["digraph amp {", '  node [fontname="Helvetica", shape=box];']
    ids: dict[int, str] = {}
    for i, node in enumerate(root.iterate()):
        ids[id(node)] = f"n{i}"
    for node in root.iterate():
        shape = "box"
        if isinstance(node, py_trees.composites.Selector):
            shape = "octagon"
        elif isinstance(node, py_trees.composites.Sequence):
            shape = "box3d"
        elif isinstance(node, Watch):
            shape = "ellipse"
        lines.append(f'  {ids[id(node)]} [label="{node.name}", shape={shape}];')
        for child in node.children:
            lines.append(f"  {ids[id(node)]} -> {ids[id(child)]};")
    lines.append("}")
    return "\n".join(lines) + "\n"
