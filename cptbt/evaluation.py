"""How a simulated run is judged: the mission's ``evaluation:`` section (simulation only)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field


class EvaluationSpec(BaseModel):
    """How a simulated run is judged against the simulator's true source (never seen by the AMP).

    ``criterion: declaration`` (TRO): the run succeeds when the planner declares a source within
    ``success_radius_m`` of the true one; a declaration farther off is a *false declaration*.
    ``criterion: arrival`` (AB appendix, the old "oracle"): the run ends, successfully, the first
    time the vehicle's true position comes within ``success_radius_m`` of the true source.
    ``criterion: maintain`` (AB §4.3, Fig. 9): a study of how long a maintain strategy keeps
    the plume. The run ends the first time contact, once made, is lost for good — a cycle after
    the first detection on which find-plume (or anything below it in the tree) drives — or at
    the time limit; ``T_M`` is AB eq. 3's ``T_Last - T_First`` of each contact, summed over the
    contacts of that span. Success = the vehicle came within ``success_radius_m`` of the true
    source before the run ended (it does not end the run). Reading chosen: AB's "T_M kept
    accumulating" while the searcher "reacquired the plume within λ": the run goes on while
    its reacquire half recovers contact, and each new contact's time is added; the time spent
    reacquiring is AB's ``T_R``, not ``T_M`` (``cptbt.batch.summary._maintain_time``); a wall
    turn by safety does not end contact.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)  # as a mission

    criterion: Literal["declaration", "arrival", "maintain"] = Field(
        default="declaration",
        description="'declaration': success = a declaration within the radius (TRO); 'arrival': "
        "success = the vehicle within the radius of the true source, which ends the run (AB); "
        "'maintain': the run ends when contact, once made, is lost for good; T_M = each "
        "contact's last minus first detection, summed (AB eq. 3, Fig. 9)",
    )
    success_radius_m: float = Field(
        default=15.0, gt=0, le=10_000, description="Success radius around the true source, m"
    )
