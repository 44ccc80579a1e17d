"""The array forms of AB's strategies (:mod:`cptbt.behaviours.strategies`) for the fleet
planner (:mod:`cptbt.fleet`): each maintain half and the crosswind cast over N vehicles at once,
proven equal to the py_trees leaves tick by tick (``tests/core/test_fleet.py``). Importing
:mod:`cptbt.behaviours.strategies` attaches them (``fleet_rule``)."""

from __future__ import annotations

import numpy as np

from cptbt.angles import sign_array, wrap_deg_array
from cptbt.behaviours.strategies import (
    CastParams,
    ConstantBetaCast,
    ConstantBetaMaintain,
    ConstantBetaParams,
    StrategyICast,
    StrategyIICast,
    StrategyIIICast,
    StrategyIIIMaintain,
    StrategyIIIParams,
    StrategyIIMaintain,
    StrategyIIParams,
    StrategyIMaintain,
    StrategyIParams,
)
from cptbt.fleet import (
    BoolArray,
    FleetPercept,
    FleetRule,
    FloatArray,
    IntArray,
    round9_near,
    upflow_array,
)

# -- array forms (the fleet planner, cptbt.fleet) ---------------------------------------------
# Blackboard keys as arrays: ``cast_sign`` and ``beta_sign`` (int, 0: unset), ``casting`` (bool).


class _StrategyMaintainFleet(FleetRule):
    """:meth:`_StrategyMaintain.decide` for N vehicles."""

    def prepare(self) -> None:
        """The shared keys."""
        self.cast_sign = self.board.array("cast_sign", np.int64, 0)

    def steer(self, p: FleetPercept, psi_u: FloatArray) -> tuple[FloatArray, IntArray]:
        """The offsets and cast signs of vehicles in the plume with a flow estimate."""
        raise NotImplementedError

    def decide(self, p: FleetPercept, running: BoolArray) -> FloatArray:
        """``psi_u + offset`` while in the plume; records the cast sign."""
        out = np.full(len(p), np.nan)
        ok = p.in_plume & p.has_flow
        if np.count_nonzero(ok):
            q = p.take(ok)
            psi_u = upflow_array(q.vx, q.vy)
            offset, cast_sign = self.steer(q, psi_u)
            out[ok] = psi_u + offset
            self.cast_sign[q.ids] = cast_sign
        return out


class StrategyIMaintainFleet(_StrategyMaintainFleet):
    """:class:`StrategyIMaintain` for N vehicles."""

    covers = (StrategyIMaintain,)
    params: StrategyIParams

    def steer(self, p: FleetPercept, psi_u: FloatArray) -> tuple[FloatArray, IntArray]:
        """No offset; the cast sign from the heading's lag behind upflow."""
        lag = wrap_deg_array(p.heading - psi_u)
        signs = sign_array(lag) if self.params.cast_rule == "lagging_heading" else sign_array(-lag)
        return np.zeros(len(p)), signs


class _CounterturningMaintainFleet(_StrategyMaintainFleet):
    """:class:`_CounterturningMaintain` for N vehicles (the sign survives pre-emption)."""

    def prepare(self) -> None:
        """Sign of beta and the contact it belongs to, per vehicle; the shared keys."""
        super().prepare()
        self.sign = np.ones(self.n, dtype=np.int64)
        self.sign_contact = np.zeros(self.n, dtype=np.int64)
        self.has_sign_contact = np.zeros(self.n, dtype=bool)
        self.beta_sign = self.board.array("beta_sign", np.int64, 0)
        self.casting = self.board.array("casting", bool, False)

    def beta_magnitude(self, p: FleetPercept) -> FloatArray:
        """``|beta|`` per vehicle, deg."""
        raise NotImplementedError

    def steer(self, p: FleetPercept, psi_u: FloatArray) -> tuple[FloatArray, IntArray]:
        """``beta`` (sign chosen on each new contact) and ``sign(beta)`` as the cast sign."""
        ids = p.ids
        new = p.contact_count != self.sign_contact[ids]
        new |= ~self.has_sign_contact[ids]
        if np.count_nonzero(new):
            flip = new & self.casting[ids] & self.has_sign_contact[ids]
            fresh = new & ~flip
            self.sign[ids[flip]] = -self.sign[ids[flip]]
            self.sign[ids[fresh]] = sign_array(wrap_deg_array(p.heading[fresh] - psi_u[fresh]))
            self.sign_contact[ids[new]] = p.contact_count[new]
            self.has_sign_contact[ids[new]] = True
        signs = self.sign[ids]
        self.beta_sign[ids] = signs
        return signs * self.beta_magnitude(p), signs


class StrategyIIMaintainFleet(_CounterturningMaintainFleet):
    """:class:`StrategyIIMaintain` for N vehicles."""

    covers = (StrategyIIMaintain,)
    params: StrategyIIParams

    def beta_magnitude(self, p: FleetPercept) -> FloatArray:
        """Zero while detecting this cycle, else ``beta_deg``."""
        return np.where(p.detected, 0.0, self.params.beta_deg)


class ConstantBetaMaintainFleet(_CounterturningMaintainFleet):
    """:class:`ConstantBetaMaintain` for N vehicles."""

    covers = (ConstantBetaMaintain,)
    params: ConstantBetaParams

    def beta_magnitude(self, p: FleetPercept) -> FloatArray:
        """``beta_deg`` for every vehicle."""
        return np.full(len(p), self.params.beta_deg)


class StrategyIIIMaintainFleet(_CounterturningMaintainFleet):
    """:class:`StrategyIIIMaintain` for N vehicles."""

    covers = (StrategyIIIMaintain,)
    params: StrategyIIIParams

    def beta_magnitude(self, p: FleetPercept) -> FloatArray:
        """``|beta(t)|`` by the schedule on the time since ``T``."""
        first = np.where(p.has_first, p.first_t, p.t)
        start = np.where(p.has_last, p.last_t, first) \
            if self.params.timer == "last_detection" else first
        early, mid = self.params.early_until_s, self.params.mid_until_s
        dt = round9_near(p.t - start, early, mid)
        b1 = self.params.beta1_deg
        bands = ((self.params.beta_early_deg, self.params.beta_mid_deg, self.params.beta_late_deg)
                 if b1 is None else (b1, 2 * b1, 3 * b1))
        return np.where(dt < early, bands[0], np.where(dt <= mid, bands[1], bands[2]))


class CrosswindCastFleet(FleetRule):
    """:class:`_CrosswindCast` (strategies I-III) for N vehicles."""

    covers = (StrategyICast, StrategyIICast, StrategyIIICast, ConstantBetaCast)
    params: CastParams

    def prepare(self) -> None:
        """The shared keys."""
        self.casting = self.board.array("casting", bool, False)
        self.cast_sign = self.board.array("cast_sign", np.int64, 0)
        self.beta_sign = self.board.array("beta_sign", np.int64, 0)

    def decide(self, p: FleetPercept, running: BoolArray) -> FloatArray:
        """Cast crosswind between λ and T_W after the last detection."""
        out = np.full(len(p), np.nan)
        give_up = self.params.give_up_s
        cond = ~p.in_plume & p.has_last & p.has_flow
        cond[cond] = round9_near(p.t - p.last_t[cond], give_up) <= give_up
        if np.count_nonzero(cond):
            ids = p.ids[cond]
            cs, bs = self.cast_sign[ids], self.beta_sign[ids]
            signs = np.where(cs != 0, np.where(cs < 0, -1, 1), np.where(bs < 0, -1, 1))
            psi_u = upflow_array(p.vx[cond], p.vy[cond])
            out[cond] = psi_u - self.params.cast_deg * signs
        self.casting[p.ids] = cond
        return out


StrategyIMaintain.fleet_rule = StrategyIMaintainFleet
StrategyIIMaintain.fleet_rule = StrategyIIMaintainFleet
StrategyIIIMaintain.fleet_rule = StrategyIIIMaintainFleet
ConstantBetaMaintain.fleet_rule = ConstantBetaMaintainFleet
for _cast in (StrategyICast, StrategyIICast, StrategyIIICast, ConstantBetaCast):
    _cast.fleet_rule = CrosswindCastFleet
