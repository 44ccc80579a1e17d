"""The plume-tracking strategies I–III of AB 2001 (Table 3), each a maintain + reacquire pair,
and AB's nominal strategy of eqs. 4-5 (``constant_beta``: β held through the contact, Fig. 9).

Each strategy registers a maintain half (``maintain_plume.strategy_N``: output while in the plume)
and a reacquire half (``reacquire_plume.strategy_N``: the crosswind cast of SPEC §6c, output from
λ to T_W after the last detection). A mission must list both halves with the same strategy;
each half declares the pairing as data (its ``contract``), which ``cptbt validate`` checks, so a
mismatched mission never reaches set-up. They share state through blackboard keys:

- ``cast_sign`` (int ±1, maintain → reacquire): the cast heads ``psi_u - cast_deg*cast_sign``.
  Strategy I writes the sign its ``cast_rule`` gives (from the actual heading vs upflow), II
  and III write ``sign(beta)``; written on every tick the maintain half has an output, so the
  reacquire half reads the value of the last in-plume cycle, T_Lost = T_Last + λ (AB eq. 3).
- ``beta_sign`` (int ±1, maintain → anyone): II and III's current ``sign(beta)``; the TRO
  cloverleaf reads it too. The cast falls back to it when ``cast_sign`` is absent.
- ``casting`` (bool, reacquire → maintain): whether the cast had an output on its last tick; a
  new contact made while casting is a *reacquisition*, which flips the sign of beta.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Literal

from py_trees.common import Access
from pydantic import Field, model_validator

from cptbt.angles import sign, wrap_deg
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept

AB_CYCLE_HZ = 10.0
"""The planning rate AB's strategies need (SPEC §2: they switch at 0.2 s and 0.5 s, λ is 1 s);
a mission ticking slower is warned of."""


class _StrategyMaintain(PlanBehaviour):
    """Maintain half of an AB strategy: output while in the plume (a detection within λ)."""

    family: ClassVar[str] = "maintain_plume"

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("cast_sign", access=Access.WRITE)

    def steer(self, p: Percept, psi_u: float) -> tuple[float, int]:
        """The offset from upflow this cycle, deg, and the cast sign to leave for reacquire."""
        raise NotImplementedError

    def decide(self, p: Percept) -> Command | None:
        """``psi_u + offset`` while in the plume; records the cast sign on the blackboard."""
        if not p.in_plume or p.flow is None:
            return None
        psi_u = p.flow.upflow_deg
        offset, cast_sign = self.steer(p, psi_u)
        cmd = self.command(psi_u + offset)
        if cmd is not None:
            self.bb.cast_sign = cast_sign
        return cmd


class StrategyParams(BehaviourParams):
    """Parameters every AB maintain half shares (AB Table 3).

    λ (1 s in AB Table 3) is the mission's ``perception.lambda_s``: it is the perception's
    contact-loss time, shared by every behaviour.
    """


class StrategyIParams(StrategyParams):
    """Parameters of AB Strategy I, maintain half (AB Table 3)."""

    cast_rule: Literal["opposite_wind_change", "lagging_heading"] = Field(
        default="opposite_wind_change",
        description="Which way the cast turns: 'opposite_wind_change' (AB §4.1, SPEC §5c) or "
        "'lagging_heading' (the sign of the heading's lag behind upflow, the former reading)",
    )


class StrategyIMaintain(_StrategyMaintain):
    """AB Strategy I, maintain: straight upflow (``psi_u``) while a detection is within λ.

    Each tick it records the sign of the cast that the reacquire half will fly
    (``psi_u - 90*cast_sign``), chosen by ``cast_rule``:

    - ``opposite_wind_change`` (default): the cast turns *opposite to the wind's recent change*
      (AB §4.1: "the vehicle should turn in the direction opposite to the change in the wind
      direction"): the plume near the searcher was laid by the older wind, so it lies on the
      side the upflow direction has just turned away from. The recent change is read from the
      heading's lag: a heading that follows ``psi_u`` through first-order dynamics trails it by
      the recent change of ``psi_u`` (with a = 5, its change over the last ~0.2 s), so
      ``cast_sign = sign(wrap(psi_u - psi))`` and the cast heads toward the side the heading
      still points to.
    - ``lagging_heading``: ``cast_sign = sign(wrap(psi - psi_u))``, the reading of AB eqs. 7–8
      with ``psi_r`` taken as the heading's lag. AB flips the sign convention of ``psi_r``
      between §4.1 and §4.2, and this reading casts *with* the wind's change; measured, it casts
      toward the plume in only 39 % of losses (SPEC §5c). Kept for comparison. It is also the
      reading of AB's summary, Table 3 ("the sign of γ is defined based on the vehicle heading
      and wind direction to cause the vehicle to reverse its crosswind direction (i.e.,
      counterturn)"): the paper's §4.1 words and its Table 3 point opposite ways, and the
      default follows §4.1, whose reasoning (the plume near the searcher was laid by the
      older wind) the measurement bears out. No result here turns on it: Fig. 10's times
      far from the source differ by -0.9 ± 5.4 s between the two (a paper reviewer's
      finding that the default's departure from Table 3 was not said).

    ``sign(0) = +1`` in both. Reading chosen: T_Lost is the last cycle the perception counts as
    in the plume (the last tick of this half), so the values recorded on that tick are
    psi(T_Lost) and psi_u(T_Lost).
    """

    variant: ClassVar[str] = "strategy_1"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "strategy_1"),),
                                            min_cycle_hz=AB_CYCLE_HZ)
    Params: ClassVar[type[BehaviourParams]] = StrategyIParams
    params: StrategyIParams

    def steer(self, p: Percept, psi_u: float) -> tuple[float, int]:
        """No offset; the cast sign by ``cast_rule`` from the heading's lag behind upflow."""
        lag = wrap_deg(p.pose.heading_deg - psi_u)
        if self.params.cast_rule == "lagging_heading":
            return 0.0, sign(lag)
        return 0.0, sign(-lag)


class _CounterturningMaintain(_StrategyMaintain):
    """Maintain half that crosses the plume at ``psi_u + beta``, ``sign(beta)`` kept per contact.

    Reading chosen: on a new contact (``p.contact_count`` increments) the sign of beta is set
    once: flipped if the contact was made while the paired cast was running (a reacquisition,
    AB: "the time varying beta(t) process is repeated with the opposite signs"); otherwise (the
    mission's first contact, or one found by find-plume after giving up) the sign that keeps
    crossing the way the searcher was moving on entering: ``sign(wrap(psi - psi_u))`` of the
    heading on the contact's first tick of this half. The sign survives pre-emption.
    """

    persistent_state: ClassVar[tuple[str, ...]] = ("beta_sign", "sign_contact")

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("beta_sign", access=Access.WRITE)
        self.bb.register_key("casting", access=Access.READ)
        self.beta_sign = 1
        self.sign_contact: int | None = None

    def initialise(self) -> None:
        """A new activation: the sign of beta and its contact are kept on purpose."""

    def beta_magnitude(self, p: Percept) -> float:
        """``|beta|`` this cycle, deg."""
        raise NotImplementedError

    def steer(self, p: Percept, psi_u: float) -> tuple[float, int]:
        """``beta`` (sign chosen on each new contact) and ``sign(beta)`` as the cast sign."""
        if p.contact_count != self.sign_contact:
            casting = bool(self.bb.get("casting")) if self.bb.exists("casting") else False
            if casting and self.sign_contact is not None:
                self.beta_sign = -self.beta_sign
            else:
                self.beta_sign = sign(wrap_deg(p.pose.heading_deg - psi_u))
            self.sign_contact = p.contact_count
        self.bb.beta_sign = self.beta_sign
        return self.beta_sign * self.beta_magnitude(p), self.beta_sign


class StrategyIIParams(StrategyParams):
    """Parameters of AB Strategy II, maintain half (AB Table 3)."""

    beta_deg: float = Field(
        default=35.0, ge=0, le=90, description="|beta|: offset from upflow when not detecting, deg"
    )


class StrategyIIMaintain(_CounterturningMaintain):
    """AB Strategy II, maintain: ``psi_u`` while detecting, ``psi_u + beta`` within λ after.

    ``|beta| = beta_deg``; its sign flips at each reacquisition (see the base class).
    """

    variant: ClassVar[str] = "strategy_2"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "strategy_2"),),
                                            min_cycle_hz=AB_CYCLE_HZ)
    Params: ClassVar[type[BehaviourParams]] = StrategyIIParams
    params: StrategyIIParams

    def beta_magnitude(self, p: Percept) -> float:
        """Zero while detecting this cycle, else ``beta_deg``."""
        return 0.0 if p.detected else self.params.beta_deg


class ConstantBetaParams(StrategyParams):
    """Parameters of AB's nominal maintain strategy (eqs. 4-5, Fig. 3)."""

    beta_deg: float = Field(
        default=35.0, ge=0, le=90,
        description="|beta|: offset from upflow held through the whole contact, detections "
        "included (AB eq. 4; Fig. 9 sweeps 0..75), deg",
    )


class ConstantBetaMaintain(_CounterturningMaintain):
    """AB's nominal strategy, maintain: ``psi_u + beta`` within λ of a detection (AB eq. 4).

    AB §3, eq. 4 and Fig. 3: "After first odor detection, the searcher travels at an angle β
    relative to upwind. The angle β is maintained until above threshold odor has not been
    detected for λ seconds": the offset holds on cycles with a detection too. That is what
    sets it apart from Strategy II (AB Table 2: straight upflow while detecting, β only
    between detections), and it is the "constant angle β ... as shown in Fig. 3" of AB Fig. 9's
    lower curves (``missions/ab2001_fig9_constant.yaml``). Its reacquire half is the cast of
    eq. 5 (``reacquire_plume.constant_beta``).

    Readings chosen: AB's "a sign that changes each time that behavior of eqn. (5) occurs" is
    read as Strategy II's: flipped on a contact made while the cast runs (a reacquisition),
    and on a contact found by find-plume taken from the entry heading (see the base class).
    ``beta_deg`` defaults to Strategy II's 35° (AB gives eq. 4 no value; Fig. 7: any β > 10°
    does well).
    """

    variant: ClassVar[str] = "constant_beta"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "constant_beta"),),
                                            min_cycle_hz=AB_CYCLE_HZ)
    Params: ClassVar[type[BehaviourParams]] = ConstantBetaParams
    params: ConstantBetaParams

    def beta_magnitude(self, p: Percept) -> float:
        """``beta_deg`` on every in-plume cycle, detecting or not."""
        return self.params.beta_deg


class StrategyIIIParams(StrategyParams):
    """Parameters of AB Strategy III (the active strategy), maintain half (AB eq. 12)."""

    beta_early_deg: float = Field(
        default=10.0, ge=0, le=90, description="|beta| while t - T_first < early_until_s, deg"
    )
    beta_mid_deg: float = Field(
        default=65.0, ge=0, le=90, description="|beta| from early_until_s to mid_until_s, deg"
    )
    beta_late_deg: float = Field(
        default=85.0, ge=0, le=90, description="|beta| once t - T_first > mid_until_s, deg"
    )
    beta1_deg: float | None = Field(
        default=None, ge=0, le=30,
        description="beta_1 of AB eq. 11: if set, |beta| is beta_1, 2 beta_1, 3 beta_1 in the "
        "three bands (AB Fig. 9's sweep), in place of the three beta_*_deg (None: the three "
        "beta_*_deg, AB eq. 12), deg",
    )
    early_until_s: float = Field(default=0.2, ge=0, description="tau_1 of AB eq. 11, s")
    mid_until_s: float = Field(default=0.5, ge=0, description="tau_2 of AB eq. 11, s")
    timer: Literal["contact", "last_detection"] = Field(
        default="last_detection",
        description="What t is measured from in the |beta| schedule: 'contact' (the contact's "
        "first detection, T_first: the letter of AB eq. 11) or 'last_detection' (restarted at "
        "every detection: the reading under which III competes with I and II, 91 % on AB's "
        "Fig. 11 grid against AB's 97 %; benchmarks/results/ab2001)",
    )

    @model_validator(mode="after")
    def _schedule_ordered(self) -> StrategyIIIParams:
        if self.early_until_s > self.mid_until_s:
            raise ValueError("early_until_s must not exceed mid_until_s")
        return self


class StrategyIIIMaintain(_CounterturningMaintain):
    """AB Strategy III, maintain: ``psi_u + beta(t)`` within λ, ``|beta|`` growing (AB eq. 11–12).

    ``|beta|`` is ``beta_early_deg`` for ``t - T < early_until_s``, ``beta_mid_deg`` up to and
    including ``mid_until_s``, ``beta_late_deg`` after (AB eq. 12's 10°, 65°, 85° by default);
    with ``beta1_deg`` set, ``beta_1``, ``2 beta_1``, ``3 beta_1`` (AB eq. 11, Fig. 9's sweep).
    Sign: see the base class. ``T`` depends on ``timer`` (SPEC §5c, which requires both
    readings):

    - ``contact``: ``T = T_first``, the current contact's first detection (redefined
      on each reacquisition): the letter of AB eq. 11 and Table 3. With AB's heading dynamics
      (a = 5) the heading never settles near upflow before ``|beta|`` reaches 65° and 85°, so
      the searcher crosses the plume almost crosswind and gains ground up-plume mainly in the
      turns: 0.15–0.37 m/s in an idealised straight plume against 1 m/s for Strategy I (SPEC
      §5c), and far below AB's 97 % on the Fig. 11 grid (benchmarks/results/ab2001).
    - ``last_detection`` (default): ``T`` is the latest detection, so the searcher holds
      near-upflow while filaments keep arriving (more often than every ``early_until_s``: the
      > 5 Hz surge of the moths AB §1 cites) and turns crosswind within ``mid_until_s`` of the
      last hit. This is the reading under which III competes with I and II at all (SPEC §5c
      expects it to reproduce AB Figs. 10-11; measured here it does not quite: 90.8 % on the
      Fig. 11 grid against AB's 97 %, and far from the source level with I and ~14 s behind II
      where AB has III ahead of both; ``benchmarks/results/ab2001/report.md``). It is the
      default (SPEC §5c fixes none) so that a mission reaching Strategy III by a variant sweep
      from another strategy (``--sweep maintain_plume.variant+...=strategy_1,strategy_3``,
      which resets the parameters) compares the strategies as AB did, not the slow letter.

    Reading chosen: eq. 12 leaves both switch instants open (eq. 11 puts the first one in the
    early band); SPEC's "10° for < 0.2 s, 65° until 0.5 s" is followed, and ``t - T`` is rounded
    to 1 ns so that 10-Hz float time grids land on the intended side.
    """

    variant: ClassVar[str] = "strategy_3"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "strategy_3"),),
                                            min_cycle_hz=AB_CYCLE_HZ)
    Params: ClassVar[type[BehaviourParams]] = StrategyIIIParams
    params: StrategyIIIParams

    def beta_magnitude(self, p: Percept) -> float:
        """``|beta(t)|`` by the schedule on the time since ``T`` (see ``timer``)."""
        if self.params.timer == "last_detection" and p.last_detection is not None:
            start = p.last_detection.t
        else:
            start = p.first_detection_t if p.first_detection_t is not None else p.t
        dt = round(p.t - start, 9)
        b1 = self.params.beta1_deg
        if dt < self.params.early_until_s:
            return self.params.beta_early_deg if b1 is None else b1
        if dt <= self.params.mid_until_s:
            return self.params.beta_mid_deg if b1 is None else 2 * b1
        return self.params.beta_late_deg if b1 is None else 3 * b1


class CastParams(BehaviourParams):
    """Parameters of the crosswind cast, the reacquire half of AB Strategies I–III (Table 3)."""

    give_up_s: float = Field(
        default=4.0,
        gt=0,
        description="T_W: after this long without a detection, give up (find-plume), s",
    )
    cast_deg: float = Field(default=90.0, ge=0, le=180, description="|gamma|: cast angle, deg")


def _cast_needs_time(params: BehaviourParams, perception: Any) -> str | None:
    """Why the cast can never drive: it runs from λ (contact lost) to T_W, so T_W must exceed λ
    (a TRO mission's λ of 8.5 s with AB's T_W of 4 s flew with no reacquire at all)."""
    give_up = getattr(params, "give_up_s", math.inf)
    if perception.lambda_s >= give_up:
        return (f"the cast runs from perception.lambda_s (contact lost) to give_up_s, but "
                f"lambda_s = {perception.lambda_s:g} s is not below give_up_s = {give_up:g} s, "
                "so it would never run; set lambda_s below give_up_s (AB Table 3: λ = 1 s, "
                "T_W = 4 s)")
    return None


class _CrosswindCast(PlanBehaviour):
    """Reacquire half of an AB strategy: ``psi_u - cast_deg*cast_sign`` from λ to T_W (SPEC §6c).

    Output only when not in the plume, after a detection, while ``t - t_last <= give_up_s``
    (T_W), and with a flow estimate; afterwards none, so find-plume takes over. The cast sign is
    the blackboard's ``cast_sign`` (from the paired maintain half), else ``beta_sign``, else +1.
    It writes ``casting`` every tick it runs. ``validate`` refuses ``give_up_s <=
    perception.lambda_s``: the cast would never run.
    """

    family: ClassVar[str] = "reacquire_plume"
    Params: ClassVar[type[BehaviourParams]] = CastParams
    params: CastParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("casting", access=Access.WRITE)
        self.bb.register_key("cast_sign", access=Access.READ)
        self.bb.register_key("beta_sign", access=Access.READ)

    def cast_sign(self) -> int:
        """The sign left by the maintain half (``cast_sign``, else ``beta_sign``, else +1)."""
        for key in ("cast_sign", "beta_sign"):
            if self.bb.exists(key) and self.bb.get(key) is not None:
                return -1 if self.bb.get(key) < 0 else 1
        return 1

    def decide(self, p: Percept) -> Command | None:
        """Cast crosswind between λ and T_W after the last detection."""
        cmd = None
        lost = not p.in_plume and p.last_detection is not None
        if lost and p.flow is not None and round(p.since_detection(), 9) <= self.params.give_up_s:
            cmd = self.command(p.flow.upflow_deg - self.params.cast_deg * self.cast_sign())
        self.bb.casting = cmd is not None
        return cmd


class StrategyICast(_CrosswindCast):
    """AB Strategy I, reacquire: cast the way the maintain half's ``cast_rule`` chose."""

    variant: ClassVar[str] = "strategy_1"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "strategy_1"),),
                                            check=_cast_needs_time)


class StrategyIICast(_CrosswindCast):
    """AB Strategy II, reacquire: counterturn, cast against ``sign(beta)`` (pairs with II)."""

    variant: ClassVar[str] = "strategy_2"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "strategy_2"),),
                                            check=_cast_needs_time)


class StrategyIIICast(_CrosswindCast):
    """AB Strategy III, reacquire: counterturn, cast against ``sign(beta)`` (pairs with III)."""

    variant: ClassVar[str] = "strategy_3"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "strategy_3"),),
                                            check=_cast_needs_time)


class ConstantBetaCast(_CrosswindCast):
    """AB's nominal strategy, reacquire (eq. 5): cast against ``sign(beta)``.

    Pairs with ``maintain_plume.constant_beta``.
    """

    variant: ClassVar[str] = "constant_beta"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "constant_beta"),),
                                            check=_cast_needs_time)


# The array forms (the fleet planner) live in their own module, attached to these classes
# (``fleet_rule``) when it is imported.
from cptbt.behaviours import strategies_fleet  # noqa: E402,F401

BEHAVIOURS = [
    BehaviourSpec.of(cls)
    for cls in (
        StrategyIMaintain,
        StrategyIIMaintain,
        StrategyIIIMaintain,
        StrategyICast,
        StrategyIICast,
        StrategyIIICast,
        ConstantBetaMaintain,
        ConstantBetaCast,
    )
]
