"""The up-flow check a likelihood-map candidate passes before it is declared.

:class:`UpflowCheck` keeps the track since the first detection and answers, for a candidate of
:class:`~cptbt.behaviours.likelihood.LikelihoodMapDeclare`, whether it may be declared; when it
may not for want of a crossing, it names the point the vehicle should fly to (the *check leg*).
The rule:

**The up-flow check** (``upflow_check_m``; None turns it off). A map can be sure of a point
short of the source: the meander carried the plume off the flow estimate's axis while the
vehicle's misses ruled out the water up-flow (TRO MSN007, 1000 runs, seed 2024: the five
declarations beyond 15 m lay 19-46 m down-flow of the source). Three tests stand between
the rule and the declaration, the last two along the current flow estimate, and the
vehicle flies what they need before the map is quite sure (*early*, the last item):

- *plume seen near* (``upflow_seen_near``): a detection no declared source explains, made
  since the search for this source began, within ``radius_m`` of the candidate. Without one
  the node drives to the candidate itself (a *visit*, counted in ``visits``): the map can be
  sure of a point where no plume was ever seen — up-flow of a source the vehicle overshot,
  whose own misses there were too few, or against a wall its passes never sampled — and
  the misses at the point move the map's mass (or the plume is found there). A visit not
  done after ``upflow_timeout_s`` ends (``visits_ended``) and holds its candidate back
  while the tree searches on, until plume is seen near it or the map moves to another
  candidate (a new visit): a candidate no plume was seen near is never declared. A
  source emits: next to it a pass detects in most cycles (the model's ``detection_prob``).
  Only with the check on (``upflow_check_m``);
- *crossing*: the track (since the search for this source began, and since the latest
  vetoing detection) must have crossed the candidate's flow line ``upflow_check_m``
  up-flow of it (give or take ``arrive_radius_m``), reaching ``upflow_band_m`` to either
  side (less ``arrive_radius_m``) and passing over the line itself (within
  ``arrive_radius_m`` of it, or from one side to the other between two cycles). Until it
  has, the node drives a *check leg* to the point that far up-flow and that far to the
  side not yet reached (the nearer first), or, both sides reached apart, to the line's
  point that far up-flow: excursions to either side made at different times leave the
  water straight up-flow unseen (two-source mission, root seed 2028: all three false
  declarations, 16-43 m short, had been passed so; none of 200 runs is with the line).
  An empty crossing at ``a`` up-flow rules out only sources beyond ``a``: until session 18
  a crossing up to twice ``upflow_check_m`` (23 m) up-flow counted, and it let through
  sources 15-21 m short (three of four false two-source declarations left on root seeds
  2027 and 2029, each passed by a sweep lane 20-23 m up-flow of the candidate).
  ``upflow_window_m`` sets how far up-flow a crossing still counts (23: the rule before,
  faster and less precise: measured in README's declaration table). With several
  sources the line must be passed over twice, more than 15 s apart
  (``upflow_crossings``; None: once with ``max_sources`` 1, twice with more; until the
  second the leg goes back to the line's point): near a source the plume is intermittent
  and one empty pass can miss it. The two-source mission's false declarations left after
  session 18 (root seeds 2024-2030: five of six, 17-57 m short, one pass each) are each
  mended by the second pass; measured in README's two-source table. A single source
  keeps one pass: a second costs T_D, and MSN007's declarations beyond 15 m were not of
  this kind. A
  side whose point lies outside the OpArea needs no crossing; nearer the up-flow wall than
  that reach (plus ``arrive_radius_m``) the crossing is looked for nearer, at the candidate
  itself against the wall (the map's mass piles up at a wall no evidence reaches). A leg
  that has not got there after ``upflow_timeout_s`` (safety held the vehicle, say) ends,
  and the candidate is declared unchecked (counted, as is a candidate declared without a
  flow direction). A leg is timed and counted once per candidate: a cycle or two of the
  map dipping below ``confidence`` resumes it (same clock) if the candidate has moved less
  than ``radius_m``. With ``upflow_fan_deg`` (20°) the sides to reach, and the veto's
  band, widen up-flow by the flow estimate's direction error: ``upflow_band_m`` plus
  ``tan(upflow_fan_deg)`` per metre up-flow (8.6 m at 10 m);
- *early* (``upflow_early_fraction``, 0.7): the visit and the leg are flown as soon as the
  map holds that fraction of ``confidence`` within ``radius_m`` of a candidate, while the
  map gathers the rest, so that they overlap the time the map takes to become sure
  instead of following it; the declaration still waits for ``confidence`` and a check
  passed by the candidate it is then sure of. An early test passes nothing unchecked (a
  leg out of time ends and is not flown early again for that candidate; once the map is
  sure, the leg has a clock of its own, as does a leg still under way then), and counts
  no veto. The early leg and the fan serve a single source (``max_sources`` 1); with
  several, neither is flown and the band keeps ``upflow_band_m``: on the two-source
  mission they were not shown to help, and measured worse (runs with a false declaration:
  11 of 600 on seeds 2026-2028 against 5 of the same 600 without; not understood).
  Measured:
  ``benchmarks/results/likelihood_map_tuning.md``, "The early leg and the fan";
- *veto*: a detection no declared source explains, made since the search for this source
  began (within ``upflow_memory_s`` if set), lying more than ``upflow_veto_near_m`` (5 m;
  ``None``: ``radius_m``, the earlier default) and at most three
  times ``upflow_check_m`` up-flow of the candidate and within ``upflow_band_m`` of its
  line, vetoes it (counted once per run of vetoed cycles): a source is not down-flow of
  its own plume, and the map, having ruled that water out, had put such a detection down to
  a false alarm. So does a *trace* there (``upflow_trace_fraction``, 0.25): a reading below
  the threshold but above that fraction of it, and above three times the median reading of
  the track's cycles without a detection (a noise floor: a noisy or offset sensor reads
  above zero in clean water, and the trace veto then needs more). Up-flow of a source there
  is no dye at all; a check leg that crossed the plume's fringe, or a filament too diluted
  to reach the threshold, has seen plume that came from farther up-flow. Limits: a single
  reading decides (each of the three study runs the trace veto was made for had exactly
  one above the level in the band), so it cannot tell a spike from a trace, and the veto
  lasts like a detection's (ending it after ``upflow_timeout_s`` lost two-source replicate
  8 of seed 2024, whose old traces in the band of a turned flow had held a candidate 45 m
  off back). The floor is a median over the cycles that speak of this source (those a
  declared source explains, or made outside the OpArea, are left out), so *rare* spikes do
  not raise it: with a sensor whose samples are at half the threshold 2% of the time
  (MSN007 runs 0-19, root seed 2024, the spikes seen by the declaration alone), one run
  of 20 never declared, its right candidate held back by one spike. A lagging sensor
  (``alpha_per_s`` 0.2) carries a decaying tail of the plume past the source into the
  band. Set ``upflow_trace_fraction: null``, or a finite ``upflow_memory_s``, for such
  sensors.
  ``trace_vetoes`` counts vetoes whose band held traces but no detection. No leg is
  flown; the tree searches on, and crossings made before the latest vetoing detection no
  longer count. A veto lasts while the map stays sure of that
  candidate: with the default ``upflow_memory_s`` (none), a single false alarm in that band
  holds a correct candidate back for the rest of this source's search (the simulator has
  no false alarms; a sensor that has them wants a finite memory), and a reversed flow turns
  the plume already seen into such detections (tidal water: set the memory shorter than
  the tide's turn).
"""

from __future__ import annotations

import math

import numpy as np

from cptbt.angles import unit
from cptbt.frames import OpArea, room
from cptbt.types import Percept, Point


class UpflowCheck:
    """The track, the check leg under way, and the counts the declaration reports.

    Args:
        reach_m: how far up-flow of the candidate the crossing must be (give or take
            ``slack_m``: an empty crossing rules out only sources farther up-flow).
        window_m: how far up-flow a crossing still counts (None: ``reach_m + slack_m``).
        band_m: how far to either side of the candidate's flow line the crossing must reach, and
            the half-width of the band in which plume seen up-flow vetoes the candidate.
        veto_beyond_m: plume seen more than this up-flow of the candidate (and no more than three
            times ``reach_m``) vetoes it.
        slack_m: how near a point counts as reached.
        memory_s: plume seen longer ago than this no longer vetoes (None: since :meth:`restart`).
        timeout_s: a check leg not done after this long ends, and its candidate passes,
            unchecked; a visit not done after this long ends, and its candidate is held back.
        fan_deg: the band widens up-flow by ``tan(fan_deg)`` per metre (the flow estimate's
            direction error): at ``a`` up-flow its half-width is ``band_m + a · tan(fan_deg)``.
        trace_level: a reading above this (the sensor's units) in the band vetoes like a
            detection, if it also stands clear of the sensor's noise floor (:meth:`trace_floor`);
            None: only detections veto.
        crossings: how many passes over the line (more than ``crossing_gap_s`` apart) the
            crossing needs.
        crossing_gap_s: passes less than this apart count once (None: :attr:`CROSSING_GAP_S`).
        near_m: a candidate needs plume seen within this of it before the crossing is looked
            for; until then the vehicle visits it (a visit that times out holds it back while
            the tree searches on). None: not needed.
    """

    CROSSING_GAP_S = 15.0
    """Passes over the line less than this apart are one crossing (a turn back over the line
    at the vehicle's 7.5-m turn radius and 1.5 m/s takes about 16 s)."""

    FLOOR_FACTOR = 3.0
    """A trace must reach this many times the median reading of the track's other cycles."""

    def __init__(self, reach_m: float, band_m: float, veto_beyond_m: float, slack_m: float,
                 memory_s: float | None, timeout_s: float, fan_deg: float = 0.0,
                 trace_level: float | None = None, near_m: float | None = None,
                 veto_near_m: float | None = None, window_m: float | None = None,
                 crossings: int = 1, crossing_gap_s: float | None = None) -> None:
        self.reach_m, self.band_m, self.veto_beyond_m = reach_m, band_m, veto_beyond_m
        self.crossings = crossings
        self.crossing_gap_s = self.CROSSING_GAP_S if crossing_gap_s is None else crossing_gap_s
        self.window_m = window_m
        self.veto_near_m = veto_beyond_m if veto_near_m is None else veto_near_m
        self.near_m = near_m
        self.visit_for: Point | None = None  # the candidate the visit under way goes to
        self.visit_t0 = math.nan
        self.visit_over = False  # the visit to visit_for timed out: its candidate is held back
        self.visits = 0  # visits started
        self.visits_ended = 0  # of those, timed out (their candidates held back)
        self.kind = "check leg"  # what the target is: a check leg's end or a visit's candidate
        self.trace_level = trace_level
        self.fan = math.tan(math.radians(fan_deg))
        self.slack_m, self.memory_s, self.timeout_s = slack_m, memory_s, timeout_s
        self.target: Point | None = None  # the check leg's end, while one is under way
        self.early_spent: Point | None = None  # a candidate whose early leg ran out of time
        self.leg_t0 = math.nan
        self.leg_early = False  # the leg under way was started before the map was sure
        self.leg_for: Point | None = None  # the candidate the leg under way checks
        self.legs = 0  # check legs started
        self.unchecked = 0  # candidates passed unchecked (a leg timed out, no flow estimate)
        self.vetoes = 0  # candidates vetoed (a run of cycles vetoed counts once)
        self.trace_vetoes = 0  # of those, vetoed by sub-threshold traces alone
        self.vetoing = False  # the last test was a veto
        self.veto_t = -math.inf  # time of the latest vetoing detection
        self.search_t0 = -math.inf  # when the search for the present source began
        self._t: list[float] = []
        self._x: list[float] = []
        self._y: list[float] = []
        self._hit: list[bool] = []
        self._seen: list[bool] = []
        self._conc: list[float] = []
        self.known_veto = False  # a detection a declared source explains vetoes too

    def record(self, t: float, at: Point, hit: bool, reading: float = 0.0,
               seen: bool | None = None) -> None:
        """One cycle of the track: where the vehicle was, whether it saw plume no declared
        source explains, its reading (NaN: none, or one that says nothing of this source:
        a declared source explains it, or it was made outside the OpArea), and whether it saw
        plume at all (None: ``hit``; with :attr:`known_veto` such plume vetoes too)."""
        if math.isfinite(at.x) and math.isfinite(at.y):
            self._t.append(t)
            self._x.append(at.x)
            self._y.append(at.y)
            self._hit.append(hit)
            self._seen.append(hit if seen is None else seen)
            self._conc.append(reading)

    def trace_floor(self) -> float:
        """The level a trace must reach: :attr:`trace_level`, or :attr:`FLOOR_FACTOR` times the
        median reading of the track's cycles without a detection if that is higher (a noisy or
        offset sensor reads above zero in clean water; a noise-free one reads 0 there)."""
        assert self.trace_level is not None
        quiet = np.asarray(self._conc)[~np.asarray(self._hit, dtype=bool)]
        quiet = quiet[np.isfinite(quiet)]
        floor = float(np.median(quiet)) if quiet.size else 0.0
        return max(self.trace_level, self.FLOOR_FACTOR * floor)

    def restart(self, t: float) -> None:
        """A source was declared (or a candidate withdrawn) at ``t``: the search for the next
        one begins; only the track and plume seen from now on count for its candidates."""
        self.search_t0, self.target, self.leg_for, self.vetoing = t, None, None, False
        self.visit_for = self.early_spent = None

    def drop(self) -> None:
        """The map is not sure of a candidate this cycle: no leg is flown. A leg under way is
        taken up again (same count, same clock) if the map is sure again of a candidate within
        ``veto_beyond_m`` of it: a one-cycle dip of confidence is not a new leg."""
        self.target, self.vetoing = None, False

    def passed(self, p: Percept, candidate: Point, area: OpArea, early: bool = False) -> bool:
        """True when ``candidate`` may be declared; else False, with :attr:`target` the check
        leg's end when a crossing is what is missing (None after a veto).

        ``early``: the map is not yet sure of ``candidate``, only nearly (the leg is flown
        ahead, while the map gathers the rest). Nothing is then passed unchecked (no flow
        estimate, or a leg out of time: the leg ends, and is not flown early again for that
        candidate; once the map is sure, a leg of its own, on a clock of its own), and a veto
        is not counted, nor does it set aside the crossings made before it.
        """
        if p.flow is None or math.hypot(p.flow.vx, p.flow.vy) < 1e-9:
            if early:
                self.target = None
                return False
            self.unchecked += 1  # no direction to call up-flow: declared unchecked, counted
            self.target, self.leg_for = None, None
            return True
        fx, fy = unit(p.flow.toward_deg)
        slack, w = self.slack_m, self.band_m
        t = np.asarray(self._t)
        dx = np.asarray(self._x) - candidate.x
        dy = np.asarray(self._y) - candidate.y
        upflow, across = -(dx * fx + dy * fy), dy * fx - dx * fy
        # Plume seen up-flow of the candidate while searching for this source: the map put it
        # down to a false alarm or another meander (it had ruled that water out), but the source
        # cannot be down-flow of its own plume. No declaration, nor check leg: the tree searches
        # on; a crossing made before the latest such detection no longer counts.
        # A sub-threshold trace there says the same: up-flow of a source there is no dye at all.
        hit = np.asarray(self._hit, dtype=bool)
        half = w + np.maximum(upflow, 0.0) * self.fan  # the band's half-width there
        where = ((t > self.search_t0) & (upflow > self.veto_near_m)
                 & (upflow <= 3 * self.reach_m) & (np.abs(across) <= half))
        if self.memory_s is not None:
            where &= t >= p.t - self.memory_s
        plume = np.asarray(self._seen, dtype=bool) if self.known_veto else hit
        seen = where & plume
        if self.trace_level is not None:  # the floor (a median) only when a reading could pass
            conc = np.asarray(self._conc)
            with np.errstate(invalid="ignore"):  # a level of 0: not 0; NaN: no reading
                trace = where & (conc > self.trace_level)
                if np.any(trace):
                    seen |= trace & (conc > self.trace_floor())
        if bool(np.any(seen)):
            self.target, self.leg_for = None, None
            if early:
                return False
            self.veto_t = max(self.veto_t, float(t[seen].max()))
            if not self.vetoing:
                self.vetoes += 1
                self.trace_vetoes += int(not np.any(where & plume))
            self.vetoing = True
            return False
        self.vetoing = False
        if not self._supported(p, candidate, t, dx, dy, hit):
            return False
        # Against the up-flow wall the crossing is looked for nearer, at the candidate itself
        # when there is no room: a map's mass piles up at a wall no evidence reaches.
        need = max(min(self.reach_m, room(area, candidate, -fx, -fy) - slack), 0.0)
        # at the wall (need short of the reach) the window ends as far past need as it would
        far = need + (slack if self.window_m is None else self.window_m - self.reach_m)
        window = ((upflow >= need - slack) & (upflow <= far)
                  & (t > max(self.veto_t, self.search_t0)))
        near, reach = across[window], half[window] - slack
        wn = w + need * self.fan
        ends = [Point(candidate.x - need * fx - s * wn * fy, candidate.y - need * fy + s * wn * fx)
                for s in (1.0, -1.0)]
        # A side whose end lies outside the OpArea has nothing to show: it counts as reached.
        left = bool(np.any(near >= reach)) or not area.contains(ends[0].x, ends[0].y)
        right = bool(np.any(near <= -reach)) or not area.contains(ends[1].x, ends[1].y)
        # ... and the track must have passed over the line itself: the water straight up-flow
        # of the candidate, where its source would be. Excursions to either side, made apart,
        # leave it unseen (two-source study, root seed 2028: the three false declarations).
        crossed = self._over_line(window, across, t)
        if left and right and crossed >= self.crossings:
            self.target, self.leg_for = None, None
            return True
        spent = self.early_spent
        if early and spent is not None and spent.distance_to(candidate) <= self.veto_beyond_m:
            self.target = None  # its early leg ran out of time: the next waits for the map
            return False
        if self.leg_for is None or self.leg_for.distance_to(candidate) > self.veto_beyond_m:
            self.leg_t0, self.leg_early = p.t, early
            self.legs += 1
        elif self.leg_early and not early:  # the map is sure now: the leg's own clock starts
            self.leg_t0, self.leg_early = p.t, False
        elif p.t - self.leg_t0 >= self.timeout_s:
            self.target, self.leg_for = None, None
            if early:
                self.early_spent = candidate
                return False
            self.unchecked += 1
            return True
        self.leg_for = candidate
        if left and right:  # both sides seen, not the line between them (or not often enough)
            self.target = Point(candidate.x - need * fx, candidate.y - need * fy)
            self.kind = "check leg"
            return False
        side = 1 if left else 0
        if not (left or right):  # neither side yet: the nearer one first
            here = p.pose.point
            side = int(here.distance_to(ends[1]) < here.distance_to(ends[0]))
        self.target, self.kind = ends[side], "check leg"
        return False

    def _over_line(self, window: np.ndarray, across: np.ndarray, t: np.ndarray) -> int:
        """How many times the track passed over the candidate's flow line inside the crossing
        window: a cycle in it within :attr:`slack_m` of the line, or two successive cycles in it
        on either side of the line; passes less than ``crossing_gap_s`` apart count once."""
        over = window & (np.abs(across) <= self.slack_m)
        over[1:] |= window[1:] & window[:-1] & (across[1:] * across[:-1] < 0.0)
        when = t[over]
        if when.size == 0:
            return 0
        return 1 + int(np.count_nonzero(np.diff(when) > self.crossing_gap_s))

    def _supported(self, p: Percept, candidate: Point, t: np.ndarray, dx: np.ndarray,
                   dy: np.ndarray, hit: np.ndarray) -> bool:
        """Whether plume was seen within :attr:`near_m` of ``candidate`` while searching for
        this source; if not, :attr:`target` is the candidate itself (a *visit*: the misses
        there move the map's mass, or the plume is found), until :attr:`timeout_s` ends it.
        A visit that timed out holds its candidate back (no target: the tree searches on)
        until plume is seen near it; a candidate more than ``veto_beyond_m`` from it is a new
        visit. A candidate no plume was seen near is not declared at all: the two-source
        study's one corner declaration (seed 2026, replicate 159, 62 m from either source) was
        a visit the vehicle never made, passed unchecked."""
        if self.near_m is None:
            return True
        d2 = dx * dx + dy * dy
        now = t > self.search_t0
        if bool(np.any(now & hit & (d2 <= self.near_m**2))):
            return True
        if self.visit_for is None or self.visit_for.distance_to(candidate) > self.veto_beyond_m:
            self.visit_t0, self.visit_over = p.t, False
            self.visits += 1
        elif not self.visit_over and p.t - self.visit_t0 >= self.timeout_s:
            self.visit_over = True
            self.visits_ended += 1
        if self.visit_over:  # held back, the tree searching on, until plume is seen near it
            self.target = None
            return False
        self.visit_for = candidate
        self.target, self.kind = candidate, "visit"
        return False

    def report(self) -> dict[str, int]:
        """The counts for ``declaration_report``."""
        return {"upflow_checks": self.legs, "unchecked": self.unchecked,
                "upflow_vetoes": self.vetoes, "trace_vetoes": self.trace_vetoes,
                "visits": self.visits, "visits_ended": self.visits_ended}
