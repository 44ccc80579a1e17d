"""The grid and likelihood-model parameters of the source map (:mod:`cptbt.behaviours.source_map`);
shared by the likelihood-map declaration and the infotaxis searchers.

"The module docstring" of the descriptions below is the likelihood model's,
:mod:`cptbt.behaviours.plume_likelihood`, which says what each parameter is in the model; for
the meander state ("Correlated meander") it is the map's, :mod:`cptbt.behaviours.source_map`.
"""

from __future__ import annotations

from pydantic import Field

from cptbt.node import BehaviourParams


class MapModelParams(BehaviourParams):
    """The grid and the likelihood model of the source map (see the module docstring)."""

    cell_m: float = Field(default=2.0, gt=0.1, le=100, description="Grid resolution, m")
    detection_prob: float = Field(
        default=0.6, gt=0, lt=1, description="p0: chance of a detection per cycle on the plume's "
        "mean axis next to the source"
    )
    detection_decay_m: float = Field(
        default=1000.0, gt=0, description="L: range over which that chance falls by a factor e, m "
        "(long by default: see the module docstring)"
    )
    false_alarm_prob: float = Field(
        default=0.02, ge=1e-9, lt=1, description="ε: chance of a detection with no plume, per "
        "cycle (at least 1e-9: below 1e-16, 1 - ε is 1 in floating point and a detection "
        "rules out every cell)"
    )
    near_spread_m: float = Field(
        default=3.0, ge=1e-3, description="σ0: cross-flow spread at the source (navigation "
        "error, puff size; at least 1 mm: 1e-300 squared is 0), m"
    )
    behind_spread_m: float | None = Field(
        default=None, ge=1e-3, description="How fast K falls off for sources down-flow of the "
        "observer (None: near_spread_m), m"
    )
    spread_deg: float = Field(
        default=12.0, ge=0, lt=80, description="φ: half-angle of the meander; the cross-flow "
        "spread grows by tan φ per metre of range, deg"
    )
    max_range_m: float = Field(
        default=250.0, gt=0, description="Detections are not traced back farther than this, m"
    )
    max_spread_m: float | None = Field(
        default=None, ge=1e-3, description="σmax: the meander's cross-flow spread stops growing "
        "at this (None: it grows with range without bound), m"
    )
    detection_weight: float = Field(
        default=0.5, gt=0, le=1, description="Tempering exponent of a detection's likelihood"
    )
    nondetection_weight: float = Field(
        default=0.3, gt=0, le=1, description="Tempering exponent of a non-detection's likelihood"
    )
    explored_radius_m: float = Field(
        default=6.0, gt=0, description="Cells within this of the vehicle's track count as "
        "explored (for map-guided reacquire), m"
    )
    mask_radius_m: float = Field(
        default=6.0, gt=0, description="Cells within this of a declared source are ruled out "
        "as another source, m"
    )
    explained_prob: float = Field(
        default=0.05, gt=0, lt=1, description="A detection a declared source's plume would "
        "cause with at least this chance is explained by it and says nothing about other sources"
    )
    strong_own_reach: bool = Field(
        default=True, description="A strong detection is explained by a declared source only "
        "as far as its plume gives strong ones, which are rare far down it (False: as far as it "
        "gives any detection, the rule before, which explained away a source in the edge of a "
        "declared one's plume)"
    )
    strong_prob: float = Field(
        default=0.68, gt=0, lt=1, description="p3: chance per cycle of a *strong* detection "
        "(see the module docstring) on the plume's axis next to the source"
    )
    strong_decay_m: float = Field(
        default=40.0, gt=0, description="L3: range over which the chance of a strong detection "
        "falls by a factor e, m"
    )
    strong_false_alarm_prob: float = Field(
        default=0.002, ge=1e-9, lt=1, description="ε3: chance of a strong detection with no "
        "plume, per cycle (at least 1e-9, as false_alarm_prob)"
    )
    trajectory_points: int = Field(
        default=200, ge=2, le=10_000, description="Back-trajectory samples per observation"
    )
    meander_memory_s: float | None = Field(
        default=None, gt=0, description="τ: correlation time of the plume's meander; with it "
        "each cell carries a meander state and cycles are correlated through it (module "
        "docstring, 'Correlated meander'); None: cycles are independent given the source, s"
    )
    instant_spread_m: float = Field(
        default=0.55, ge=0, description="With meander_memory_s: the plume's width about its "
        "instantaneous axis grows as σi(a)² = σ0² + this · a (relative dispersion, 2 K_c / U), m"
    )
    instant_near_spread_m: float | None = Field(
        default=None, ge=1e-3, description="With meander_memory_s: σi(0), the plume's width about "
        "its instantaneous axis at the source; the rest of σ0 persists like the meander (None: "
        "σ0, all of it instantaneous), m"
    )
    meander_bins: int = Field(
        default=9, ge=3, le=41, description="With meander_memory_s: discrete meander states "
        "per cell"
    )
