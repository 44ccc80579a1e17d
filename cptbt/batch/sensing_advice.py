"""Warnings on sensing settings the simulated world makes hopeless, for
:func:`cptbt.batch.scenario.advisories`: a detection threshold the plume never reaches, or
reaches only next to its source, and a contact-loss time λ no shorter than the time limit."""

from __future__ import annotations

import functools
import math

import numpy as np

from cptbt.batch.sim_advice import plain
from cptbt.mission import MissionBase, Problem
from cptbt.sim.world import EnvironmentParams, World

MARGIN = 1.1
"""A threshold is warned of only at this many times the peaks found: they are taken at the
puffs' centres, and where puffs overlap the sum peaks between them, a few per cent higher
(4% on AB's plume, 1% on TRO's, against a 2-cm grid). It was 1.5: a review's MSN007 at
threshold 5, 1.3 times the peak beyond 10 m, was not warned of and saw nothing in 1 800 s (a
vehicle seldom passes through a puff's very centre)."""

NEAR_SOURCE_M = 10.0
"""A threshold the plume reaches only within this of a source is warned of: the plume
cannot be found from afar."""


MAX_PUFFS = 20_000
"""The check releases at most this many puffs a source (a dense plume's minutes had taken
validate 279 s): its minutes are cut short, and only what they reach is judged."""

CENTRES = 1_000
"""Puff centres at which the peaks are looked for: the nearest to the sources, and the nearest
beyond :data:`NEAR_SOURCE_M` (the concentration falls with distance)."""


@functools.lru_cache(maxsize=32)
def _peaks(params_json: str, near_m: float) -> tuple[float, float | None]:
    params = EnvironmentParams.model_validate_json(params_json)
    world = World(params, np.zeros((0, 2)))
    speed = max(params.flow.mean_speed_mps, 1e-3)
    horizon = min(600.0, max(120.0, 2.0 * near_m / speed),
                  MAX_PUFFS / params.plume.release_rate_hz)
    sources = np.asarray(world.sources_xy_m, dtype=float).reshape(-1, 2)
    plumes = [world.plume, *world.extra_plumes]
    peak, far = 0.0, None
    for _ in range(math.ceil(horizon / 10.0)):
        world.warm_up(10.0)
        centres = [p.positions for p in plumes if len(p.positions)]
        if not centres:
            continue
        xy = np.vstack(centres)
        gap = np.min(np.hypot(xy[:, None, 0] - sources[None, :, 0],
                              xy[:, None, 1] - sources[None, :, 1]), axis=1)
        order = np.argsort(gap, kind="stable")
        peak = max(peak, float(world.concentration_at(xy[order[:CENTRES]]).max()))
        beyond = order[gap[order] > near_m][:CENTRES]
        if len(beyond):
            top = float(world.concentration_at(xy[beyond]).max())
            far = top if far is None else max(far, top)
    return peak, far


def plume_peaks(params: EnvironmentParams, near_m: float = NEAR_SOURCE_M,
                ) -> tuple[float, float | None]:
    """The plume's highest concentration anywhere, and beyond ``near_m`` of every source (None:
    no puff got that far in the minutes looked at), over its first minutes from the source (at
    least 120 s, and the time the mean flow takes to carry a puff twice ``near_m``, at most
    600 s or :data:`MAX_PUFFS` releases): the largest value at the puff centres nearest the
    sources and nearest beyond ``near_m`` (a puff's peak; a sensor reads no more, before its
    own lag or noise), sampled every 10 s. The world's own seed: the same numbers every time;
    a world looked at once per process (a sweep's configurations share it)."""
    return _peaks(params.model_dump_json(), near_m)


def threshold_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A detection threshold above the plume's peak (no detection but from sensor noise), or
    above what it reaches beyond :data:`NEAR_SOURCE_M` of a source (a threshold in other units
    than the simulated plume's, say)."""
    threshold = mission.perception.threshold
    peak, far = plume_peaks(params)
    key = ("perception", "threshold")
    if peak <= 0.0:  # an attacker's source 400 m outside read "about 0, at its source"
        return [(key, f"{plain(threshold)}: the simulated plume holds no puff in its first "
                      "minutes (a source beyond the simulated water, the OpArea and "
                      f"{plain(params.flow.margin_m)} m about it, releases none that stay): no "
                      "run can detect it but from sensor noise")]
    if threshold >= MARGIN * peak:
        return [(key, f"{plain(threshold)} is above the simulated plume's highest "
                      f"concentration (about {peak:.3g}, at its source): no run can detect it but "
                      "from sensor noise (the plume's units: environment.plume.puff_mass)")]
    if far is not None and threshold >= MARGIN * far:  # nothing seen beyond: nothing said
        return [(key, f"{plain(threshold)} is reached by the simulated plume only within "
                      f"{NEAR_SOURCE_M:g} m of its source (beyond, about {far:.3g} at most): the "
                      "plume cannot be found from afar")]
    return []


def lambda_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A contact-loss time λ as long as the AMP's time limit: contact once made is never lost
    before the run ends (track-out, reacquire and the declarations that count lost contacts
    never run)."""
    lam, limit = mission.perception.lambda_s, mission.time_limit_s
    if lam < limit:
        return []
    return [(("perception", "lambda_s"),
             f"{plain(lam)} s, no shorter than the time limit ({plain(limit)} s): a contact "
             "once made is never lost before the run ends (no track-out, reacquire or "
             "lost-contact declaration)")]
