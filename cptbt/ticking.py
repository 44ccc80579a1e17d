"""A direct ticker for the arbitration tree: py_trees semantics without the generator machinery.

``py_trees`` ticks through nested generators and debug logging, which costs more than the
behaviours' own work at the 10 Hz, 10,000-mission scale of AB's studies. :func:`tick` walks the
same tree with the same rules — those of ``Behaviour.tick``, ``Selector.tick`` and
``Sequence.tick`` (memory off) in py_trees 2.x: when ``initialise``, ``update`` and ``stop``/
``terminate`` are called, which lower-priority children are invalidated, what ``current_child``
becomes — and calls the nodes' own ``terminate()`` (composites: ``stop()``).
``tests/core/test_ticking.py`` checks, on random trees and random scripts, that every node sees
the same calls and ends each tick in the same status as under ``tick_once()``. Trees with other
composites or decorators fall back to py_trees.
"""

from __future__ import annotations

import py_trees
from py_trees.behaviour import Behaviour
from py_trees.common import Status
from py_trees.composites import Selector, Sequence

RUNNING, SUCCESS, FAILURE, INVALID = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID


def supports(root: Behaviour) -> bool:
    """Whether :func:`tick` reproduces py_trees exactly for this tree."""
    for node in root.iterate():
        if isinstance(node, (Selector, Sequence)):
            if node.memory or type(node).tick not in (Selector.tick, Sequence.tick):
                return False
        elif (isinstance(node, py_trees.composites.Composite) or node.children
              or type(node).tick is not Behaviour.tick):
            return False
    return True


def tick(node: Behaviour) -> Status:
    """Tick ``node`` once, as ``node.tick_once()`` would; returns its new status."""
    if isinstance(node, Selector):
        return _selector(node)
    if isinstance(node, Sequence):
        return _sequence(node)
    if node.status != RUNNING:
        node.initialise()
    status = node.update()
    if status != RUNNING:
        node.terminate(status)  # Behaviour.stop() for a leaf, without its eager debug logging
    node.status = status
    return status


def _stop(node: Behaviour, status: Status) -> None:
    if node.children:
        node.stop(status)
    else:
        node.terminate(status)
        node.status = status


def _selector(node: Selector) -> Status:
    children = node.children
    if node.status != RUNNING:
        node.current_child = children[0] if children else None
        node.initialise()
    if not children:
        node.current_child = None
        node.stop(FAILURE)
        return FAILURE
    previous = node.current_child
    for child in children:
        status = tick(child)
        if status in (RUNNING, SUCCESS):
            node.current_child = child
            if previous is None or previous != child:
                passed = False
                for other in children:
                    if passed and other.status != INVALID:
                        _stop(other, INVALID)
                    if other == child:
                        passed = True
            if status == SUCCESS:
                node.stop(status)
            else:
                node.status = status
            return status
    node.stop(FAILURE)
    node.current_child = children[-1]
    return FAILURE


def _sequence(node: Sequence) -> Status:
    children = node.children
    if node.status != RUNNING:
        node.current_child = children[0] if children else None
        for child in children:
            if child.status != INVALID:
                _stop(child, INVALID)
        node.initialise()
    else:
        node.current_child = children[0] if children else None
    if not children:
        node.current_child = None
        node.stop(SUCCESS)
        return SUCCESS
    last = len(children) - 1
    for index, child in enumerate(children):
        status = tick(child)
        if status != SUCCESS:
            for other in children[index + 1 :]:
                if other.status != INVALID:
                    _stop(other, INVALID)
            if status != RUNNING:
                node.stop(status)
            else:
                node.status = status
            return status
        if index < last:
            node.current_child = children[index + 1]
    node.stop(SUCCESS)
    return SUCCESS
