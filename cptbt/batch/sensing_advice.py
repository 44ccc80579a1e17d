"""Warnings on sensing settings the simulated world makes hopeless, for
:func:`cptbt.batch.scenario.advisories`: a detection threshold the plume never reaches, or
reaches only next to its source, a contact-loss time λ no shorter than the time limit, a
noisy or dropping fluorometer, a noisy ADCP, and sensors that leave the planner blind (the
vehicle's and the flow's own warnings: :mod:`cptbt.batch.sim_advice`)."""

from __future__ import annotations

import functools
import math

import numpy as np

from cptbt.batch.sim_advice import (
    WEAK_CURRENT_MPS,
    plain,
    two_figures,
    two_figures_up,
)
from cptbt.mission import MissionBase, Problem
from cptbt.policy import RELINQUISH_OUTSIDE_M
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


NOISE_ALARMS_PER_S = 1e-3
"""A simulated fluorometer whose noise alone would make more false detections than this in
clean water (one every 1 000 s of mission) is warned of."""


def clean_water_alarm(noise_std: float, threshold: float, samples: float) -> float:
    """The chance that a planning cycle in clean water reads above ``threshold`` from the
    fluorometer's Gaussian noise alone: the cycle's reading is the largest of its ``samples``
    (the perception keeps the cycle's maximum; a mean count, when cycles get 4 or 5), so
    ``1 - Φ(threshold / noise_std)^samples``."""
    if noise_std <= 0.0:
        return 0.0
    below = 0.5 * (1.0 + math.erf(threshold / (noise_std * math.sqrt(2.0))))
    return -math.expm1(max(samples, 1.0) * math.log(below)) if below > 0.0 else 1.0


def quiet_threshold(noise_std: float, samples: float, cycle_hz: float) -> float:
    """The lowest threshold at which that noise makes at most :data:`NOISE_ALARMS_PER_S`
    false detections a second (bisection on :func:`clean_water_alarm`; inf if none does)."""
    limit = NOISE_ALARMS_PER_S / cycle_hz
    lo, hi = 0.0, 40.0 * noise_std
    if not math.isfinite(hi) or clean_water_alarm(noise_std, hi, samples) > limit:
        return math.inf
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if clean_water_alarm(noise_std, mid, samples) > limit else (lo, mid)
    return hi


def dropout_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A fluorometer that drops so many samples that half the planning cycles or more have no
    reading at all (a cycle reads the largest of its samples; one with none reads nothing,
    neither plume nor clean water): at ``dropout_prob: 1`` a review's runs timed out as if
    in clean water."""
    sensor = params.fluorometer
    samples = max(sensor.rate_hz / mission.cycle_hz, 1.0)
    blind = sensor.dropout_prob ** samples
    if blind < 0.5:
        return []
    what = ("every sample is dropped: the vehicle can never detect plume"
            if sensor.dropout_prob >= 1.0 else
            f"{two_figures(100 * blind)}% of planning cycles would have no reading "
            + (f"(every one of their {samples:.3g} samples dropped)" if samples > 1
               else "(their one sample dropped)"))
    return [(("environment", "fluorometer", "dropout_prob"),
             f"{plain(sensor.dropout_prob)}: {what}")]


def sensor_rate_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """Sensors whose settings leave the planner without what it reads (an attacker's review:
    each validated silently and flew a degenerate run): a fluorometer sampling slower than
    every other planning cycle (a cycle with no sample reads nothing); an ADCP giving fewer
    than one sample in the flow window, or a mean current at or above
    ``perception.max_flow_speed_mps`` (every sample dropped as faulty: no command 44% of the
    time, 13.7 m outside); a navigation drift as large as the success radius."""
    out: list[Problem] = []
    per_cycle = params.fluorometer.rate_hz / mission.cycle_hz
    if per_cycle < 0.5:
        out.append((("environment", "fluorometer", "rate_hz"),
                    f"{plain(params.fluorometer.rate_hz)} Hz: a sample every "
                    f"{1.0 / params.fluorometer.rate_hz:.3g} s, so at most "
                    f"{two_figures(100 * per_cycle)}% of planning cycles have a reading (one "
                    "without reads nothing, neither plume nor clean water)"))
    steer = any(e.contract.needs_flow for e in mission.entries()) and \
        mission.perception.flow_source != "none"
    window, rate = mission.perception.flow_window_s, params.adcp.rate_hz
    if steer and rate * window < 1.0:
        out.append((("environment", "adcp", "rate_hz"),
                    f"{plain(rate)} Hz: fewer than one flow sample in perception.flow_window_s "
                    f"({plain(window)} s), so the flow estimate the behaviours steer by is "
                    "missing or held most of the time"))
    gate, current = mission.perception.max_flow_speed_mps, params.flow.mean_speed_mps
    if steer and current >= gate:
        out.append((("perception", "max_flow_speed_mps"),
                    f"{plain(gate)} m/s is no faster than the simulated mean current "
                    f"({plain(current)} m/s): flow samples are dropped as faulty, so the flow "
                    "estimate the behaviours steer by is missing"))
    drift, radius = params.navigation.drift_std_m, mission.evaluation.success_radius_m
    if drift >= radius and mission.evaluation.criterion == "declaration":  # arrival is judged
        # on the true track (a diff review: AB missions were told of "declared points")
        out.append((("environment", "navigation", "drift_std_m"),
                    f"{plain(drift)} m: the position estimate drifts as far as the success "
                    f"radius ({plain(radius)} m) between fixes, so declared points and the "
                    f"OpArea's walls ({RELINQUISH_OUTSIDE_M:g} m outside gives control back, "
                    "by the estimate) are that far off"))
    return out


ADCP_DIRECTION_ERROR_DEG = 20.0
"""An ADCP noisy enough that the windowed mean's direction errs by more than this is warned of."""


def adcp_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """An ADCP too noisy for the flow estimate, when behaviours steer by it: most samples
    beyond ``perception.max_flow_speed_mps`` (dropped: a review's 100 m/s noise left the
    tree without a command 44% of the time and the watchdog ended the run), or the windowed
    mean's direction off by more than :data:`ADCP_DIRECTION_ERROR_DEG` (the noise of a mean
    of ``window · rate`` samples against the mean current)."""
    sigma = params.adcp.noise_std_mps
    steer = any(e.contract.needs_flow for e in mission.entries())
    if sigma <= 0.0 or not steer or mission.perception.flow_source == "none":
        return []
    where = ("environment", "adcp", "noise_std_mps")
    gate = mission.perception.max_flow_speed_mps
    dropped = math.exp(-gate * gate / (2.0 * sigma * sigma))  # |noise| beyond the gate
    if dropped >= 0.5:
        return [(where, f"{plain(sigma)} m/s: {two_figures(100 * dropped)}% of the flow "
                 f"samples would be faster than perception.max_flow_speed_mps ({plain(gate)} "
                 "m/s) and dropped, so the flow estimate the behaviours steer by is missing or "
                 "rests on a few samples")]
    current = params.flow.mean_speed_mps
    if current < WEAK_CURRENT_MPS:  # no direction to miss: pace_advice warns of the current
        return []
    samples = max(mission.perception.flow_window_s * params.adcp.rate_hz, 1.0)
    error = math.degrees(math.atan2(sigma / math.sqrt(samples), current))
    if error > ADCP_DIRECTION_ERROR_DEG:
        return [(where, f"{plain(sigma)} m/s: the flow estimate, a mean of about "
                 f"{samples:.0f} samples, would still point about {error:.0f}° off the mean "
                 f"current ({plain(params.flow.mean_speed_mps)} m/s); lengthen "
                 "perception.flow_window_s or lower the noise")]
    return []


def noise_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A fluorometer noise that makes detections in clean water common (measured on MSN007,
    20 runs each: noise 0.1 against TRO's threshold 0.2, ~19% of cycles, and the TRO rule
    declared 17 times, 71 m off on average; 0.06, ~0.4%, and the likelihood map declared once
    30 m off). The rate is per second of mission, so a faster planning cycle (fewer samples
    a cycle, more cycles) is judged alike; a sensor's own output threshold ``tau`` above the
    perception's is the one a reading must pass."""
    sensor = params.fluorometer
    threshold = mission.perception.threshold
    samples = max(sensor.rate_hz / mission.cycle_hz, 1.0)
    # a sensor slower than the cycle leaves cycles without a sample (no reading, no alarm)
    cycles_hz = min(mission.cycle_hz, sensor.rate_hz)
    bar = max(threshold, sensor.tau)
    alarm = clean_water_alarm(sensor.noise_std, bar, samples)
    per_s = alarm * cycles_hz
    if per_s <= NOISE_ALARMS_PER_S:
        return []
    share = "nearly all" if alarm >= 0.995 else f"{two_figures(100 * alarm)}% of"
    every = ("nearly every cycle" if alarm >= 0.995
             else f"about one false detection every {two_figures(1.0 / per_s)} s")
    each = f"the largest of {samples:.3g} samples each" if samples > 1 else "one sample each"
    good = quiet_threshold(sensor.noise_std, samples, cycles_hz)
    fix = (f"a threshold of {two_figures_up(good)} or more keeps it under one every 1 000 s"
           if math.isfinite(good) else "no threshold keeps it rare")
    return [(("environment", "fluorometer", "noise_std"),
             f"{plain(sensor.noise_std)} against perception.threshold {plain(threshold)}"
             + (f" (the sensor's own tau {plain(sensor.tau)} above it)"
                if sensor.tau > threshold
                else "") + ": in clean water "
             f"the noise alone reads above the threshold in {share} planning cycles ({each}), "
             f"{every}; the tracker chases them and a declaration can land anywhere ({fix})")]
