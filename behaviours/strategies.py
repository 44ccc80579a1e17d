"""The plume-tracking strategies I–III of AB 2001 (Table 3), each a maintain + reacquire pair.

Each strategy registers a maintain half (``maintain_plume.strategy_N``: output while in the plume)
and a reacquire half (``reacquire_plume.strategy_N``: the crosswind cast of SPEC §6c, output from
λ to T_W after the last detection). A mission must list both halves with the same strategy;
each half declares the pairing as data (its ``contract``), which ``cptbt validate`` checks, so a
mismatched mission never reaches set-up. They share state through blackboard keys:

- ``cast_sign`` (int ±1, maintain → reacquire): the cast heads ``psi_u - cast_deg*cast_sign``.
  Strategy I writes ``sign(wrap(psi - psi_u))`` (actual heading vs upflow), II and III write
  ``sign(beta)``; written on every tick the maintain half has an output, so the reacquire half
  reads the value of the last in-plume cycle, which is T_Lost = T_Last + λ (AB eq. 3).
- ``beta_sign`` (int ±1, maintain → anyone): II and III's current ``sign(beta)``; the TRO
  cloverleaf reads it too. The cast falls back to it when ``cast_sign`` is absent.
- ``casting`` (bool, reacquire → maintain): whether the cast had an output on its last tick; a
  new contact made while casting is a *reacquisition*, which flips the sign of beta.
"""

from __future__ import annotations

from typing import Any, ClassVar

from py_trees.common import Access
from pydantic import Field, model_validator

from cptbt.angles import sign, wrap_deg
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept


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


class StrategyIParams(BehaviourParams):
    """Parameters of AB Strategy I, maintain half (AB Table 3).

    λ (1 s in AB Table 3) is the mission's ``perception.lambda_s``: it is the perception's
    contact-loss time, shared by every behaviour.
    """


class StrategyIMaintain(_StrategyMaintain):
    """AB Strategy I, maintain: straight upflow (``psi_u``) while a detection is within λ.

    Each tick it records ``cast_sign = sign(wrap(psi - psi_u))`` with ``psi`` the actual heading
    (``p.pose.heading_deg``): it lags a turning flow, so the cast turns against the flow's last
    drift (AB eqs. 7–8 as SPEC §5c writes them, ``sign(0) = +1``).

    Reading chosen: T_Lost is the last cycle the perception counts as in the plume (the last tick
    of this half), so the values recorded on that tick are psi(T_Lost) and psi_u(T_Lost).
    """

    variant: ClassVar[str] = "strategy_1"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "strategy_1"),))
    Params: ClassVar[type[BehaviourParams]] = StrategyIParams
    params: StrategyIParams

    def steer(self, p: Percept, psi_u: float) -> tuple[float, int]:
        """No offset; the cast sign from the heading's lag behind upflow."""
        return 0.0, sign(wrap_deg(p.pose.heading_deg - psi_u))


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


class StrategyIIParams(StrategyIParams):
    """Parameters of AB Strategy II, maintain half (AB Table 3)."""

    beta_deg: float = Field(
        default=35.0, ge=0, le=90, description="|beta|: offset from upflow when not detecting, deg"
    )


class StrategyIIMaintain(_CounterturningMaintain):
    """AB Strategy II, maintain: ``psi_u`` while detecting, ``psi_u + beta`` within λ after.

    ``|beta| = beta_deg``; its sign flips at each reacquisition (see the base class).
    """

    variant: ClassVar[str] = "strategy_2"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "strategy_2"),))
    Params: ClassVar[type[BehaviourParams]] = StrategyIIParams
    params: StrategyIIParams

    def beta_magnitude(self, p: Percept) -> float:
        """Zero while detecting this cycle, else ``beta_deg``."""
        return 0.0 if p.detected else self.params.beta_deg


class StrategyIIIParams(StrategyIParams):
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
    early_until_s: float = Field(default=0.2, ge=0, description="tau_1 of AB eq. 11, s")
    mid_until_s: float = Field(default=0.5, ge=0, description="tau_2 of AB eq. 11, s")

    @model_validator(mode="after")
    def _schedule_ordered(self) -> StrategyIIIParams:
        if self.early_until_s > self.mid_until_s:
            raise ValueError("early_until_s must not exceed mid_until_s")
        return self


class StrategyIIIMaintain(_CounterturningMaintain):
    """AB Strategy III, maintain: ``psi_u + beta(t)`` within λ, ``|beta|`` growing (AB eq. 11–12).

    ``|beta|`` is ``beta_early_deg`` for ``t - T_first < early_until_s``, ``beta_mid_deg`` up to
    and including ``mid_until_s``, ``beta_late_deg`` after; ``T_first`` is the current contact's
    first detection (redefined on each reacquisition). Sign: see the base class.

    Reading chosen: eq. 12 leaves both switch instants open (eq. 11 puts the first one in the
    early band); SPEC's "10° for < 0.2 s, 65° until 0.5 s" is followed, and ``t - T_first`` is
    rounded to 1 ns so that 10-Hz float time grids land on the intended side.
    """

    variant: ClassVar[str] = "strategy_3"
    contract: ClassVar[Contract] = Contract(pairs_with=(("reacquire_plume", "strategy_3"),))
    Params: ClassVar[type[BehaviourParams]] = StrategyIIIParams
    params: StrategyIIIParams

    def beta_magnitude(self, p: Percept) -> float:
        """``|beta(t)|`` by the schedule on the time since the contact's first detection."""
        first = p.first_detection_t if p.first_detection_t is not None else p.t
        dt = round(p.t - first, 9)
        if dt < self.params.early_until_s:
            return self.params.beta_early_deg
        if dt <= self.params.mid_until_s:
            return self.params.beta_mid_deg
        return self.params.beta_late_deg


class CastParams(BehaviourParams):
    """Parameters of the crosswind cast, the reacquire half of AB Strategies I–III (Table 3)."""

    give_up_s: float = Field(
        default=4.0,
        gt=0,
        description="T_W: after this long without a detection, give up (find-plume), s",
    )
    cast_deg: float = Field(default=90.0, ge=0, le=180, description="|gamma|: cast angle, deg")


class _CrosswindCast(PlanBehaviour):
    """Reacquire half of an AB strategy: ``psi_u - cast_deg*cast_sign`` from λ to T_W (SPEC §6c).

    Output only when not in the plume, after a detection, while ``t - t_last <= give_up_s``
    (T_W), and with a flow estimate; afterwards none, so find-plume takes over. The cast sign is
    the blackboard's ``cast_sign`` (from the paired maintain half), else ``beta_sign``, else +1.
    It writes ``casting`` every tick it runs.
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
    """AB Strategy I, reacquire: cast away from the flow's last drift (pairs with strategy_1)."""

    variant: ClassVar[str] = "strategy_1"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "strategy_1"),))


class StrategyIICast(_CrosswindCast):
    """AB Strategy II, reacquire: counterturn, cast against ``sign(beta)`` (pairs with II)."""

    variant: ClassVar[str] = "strategy_2"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "strategy_2"),))


class StrategyIIICast(_CrosswindCast):
    """AB Strategy III, reacquire: counterturn, cast against ``sign(beta)`` (pairs with III)."""

    variant: ClassVar[str] = "strategy_3"
    contract: ClassVar[Contract] = Contract(pairs_with=(("maintain_plume", "strategy_3"),))


BEHAVIOURS = [
    BehaviourSpec.of(cls)
    for cls in (
        StrategyIMaintain,
        StrategyIIMaintain,
        StrategyIIIMaintain,
        StrategyICast,
        StrategyIICast,
        StrategyIIICast,
    )
]
