"""The mission file: one pydantic model, validated once at the door (STYLE 7).

A mission's behaviour list is checked against the registry: each entry is ``family: {variant:
name, <params>}`` and its params are validated by that variant's own frozen model. The full model
is built per registry (and per simulator environment model, which only the application layer
knows), so ``cptbt schema`` can print a JSON Schema that covers every installed variant.
"""

from __future__ import annotations

import re
import unicodedata
from functools import cache
from typing import Annotated, Any, Literal, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    create_model,
    model_validator,
)

from cptbt.evaluation import EvaluationSpec
from cptbt.frames import OpArea, PlanningFrame
from cptbt.geodesy import GeoPoint, LocalFrame
from cptbt.mission_a import MissionASpec
from cptbt.node import BehaviourParams, Contract
from cptbt.perception import PerceptionSettings
from cptbt.registry import BehaviourSpec, Registry, UnknownBehaviourError
from cptbt.study_spec import StudySpec
from cptbt.types import Point

Coord = tuple[float, float]


FINITE = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
"""Every section of a mission: frozen, unknown keys rejected, numbers finite."""

RECTANGLE_TOL_FRACTION = 0.01
"""An OpArea's corners may lie this fraction of its diagonal (or 1 m, if more) off a rectangle."""

NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,79}$"
"""A mission name is a safe file name: it becomes a folder of ``cptbt run``'s outputs."""

REMOVED_VARIANTS: dict[tuple[str, str], str] = {
    ("declare_source", "oracle"): "the oracle is no longer a behaviour (the planner never sees "
    "the true source): remove this entry and write 'evaluation: {criterion: arrival, "
    "success_radius_m: 1}'",
}
"""Variants of earlier versions that were removed, with how to migrate."""

Place = Literal["start", "home", "source"]
Loc = tuple[str | int, ...]
Problem = tuple[Loc, str]


class OpAreaSpec(BaseModel):
    """The OpArea as written: four corners in the mission's frame."""

    model_config = FINITE

    corners: list[Coord] = Field(
        min_length=4, max_length=4, description="Four corners, [a, b] each, in the mission frame; "
        "they must form a rectangle (each corner within 1% of the diagonal, or 1 m, of it), "
        "taken in any order (the rectangle is the one through the four points)"
    )
    x_axis_bearing_deg: float | None = Field(
        default=None, ge=-360, le=360,
        description="Compass bearing of the planning +x axis (default: along the long side, "
        "bearing in [0, 180)); must be parallel to a side; only for frames 'ne' and 'geodetic'",
    )
    geodetic_centre_deg: Coord | None = Field(
        default=None,
        description="[latitude, longitude] (decimal degrees, WGS-84) of the N-E origin, the "
        "OpArea centre. Frame 'geodetic': default is the corners' centre; frame 'ne': optional, "
        "lets outputs report latitude/longitude",
    )


def _exact(v: float) -> str:
    """A number as written (every digit it needs): 180.0003, not ``:g``'s 180."""
    text = repr(float(v))
    return text.removesuffix(".0")


def latlon_problem(c: Coord) -> str | None:
    """Why ``c`` is not ``[latitude, longitude]`` (with its values, every digit), or None."""
    if -90 < c[0] < 90 and -180 <= c[1] <= 180:
        return None
    return (f"[{_exact(c[0])}, {_exact(c[1])}] is not [latitude, longitude]: latitude must lie "
            "in (-90, 90) and longitude in [-180, 180]")


class MissionBase(BaseModel):
    """Fields every mission has; :func:`mission_model` adds the behaviour list's schema.

    Cross-field rules (OpArea geometry, places inside the OpArea, vehicle limits, behaviour
    contracts) are checked after the fields; each problem names the key it is about (see
    :meth:`problems`).
    """

    model_config = FINITE

    name: str = Field(
        pattern=NAME_PATTERN,
        description="Mission identifier: letters, digits, '.', '_' and '-' (it names output "
        "folders)",
    )
    description: str = Field(default="", max_length=10_000, description="Free text")
    frame: Literal["ne", "planning", "geodetic"] = Field(
        default="ne",
        description="Frame of every coordinate in this file: 'ne' = [north, east] metres; "
        "'planning' = [x, y] metres of the planning frame itself (SPEC §1: the OpArea an "
        "axis-aligned box, every angle measured from +x toward +y; no compass, so outputs "
        "give no north or latitude/longitude); 'geodetic' = [latitude, longitude] decimal "
        "degrees (WGS-84)",
    )
    op_area: OpAreaSpec = Field(description="The operating area: a rectangle (SPEC §1)")
    home: Coord = Field(description="Where the vehicle goes after declaring, in the mission frame")
    start: Coord | None = Field(
        default=None, description="Move-to-field goal and the vehicle's starting point"
    )
    allow_outside: list[Place] = Field(
        default_factory=list,
        description="Places allowed outside the OpArea (default: none): 'start', 'home', "
        "'source' (the simulator's)",
    )
    speed_mps: float = Field(default=1.5, gt=0, le=20, description="Cruise speed command, m/s")
    cycle_hz: float = Field(
        default=1.0, ge=0.01, le=100,
        description="Planner cycle rate, Hz. At least 0.01 Hz (a 100 s cycle): the planner "
        "reacts, and the time limit and OpArea are judged, once a cycle, and the behaviours' "
        "timings (contact loss λ, turn and leg times) are seconds; a slower rate is a slip "
        "such as 0.0001 for 1. The cycle period must not exceed time_limit_s",
    )
    turn_guard_radius_m: float | None = Field(
        default=None, gt=0, le=1000,
        description="The vehicle's tightest turn, m. When given, a command needing more than "
        "90° of turn is started on the side that keeps the turning circle inside the OpArea "
        "(the autopilot turns the short way); see cptbt.turns. Off by default",
    )
    time_limit_s: float = Field(
        default=3600.0, gt=0, le=7 * 86400, description="AMP time limit, s"
    )
    perception: PerceptionSettings = Field(
        default_factory=PerceptionSettings,
        description="Detection threshold, contact-loss time λ and flow estimate (SPEC §2)",
    )
    evaluation: EvaluationSpec = Field(
        default_factory=EvaluationSpec,
        description="How simulated runs are judged against the true source (simulation only)",
    )
    behaviours: list[Any] = Field(min_length=1, description="Behaviours, highest priority first")
    environment: Any = Field(default=None, description="Simulated environment (simulator only)")
    mission_a: MissionASpec | None = Field(
        default=None,
        description="The vehicle's own pre-programmed mission and when the AMP takes over "
        "(SPEC §9); without it the AMP drives from t = 0",
    )
    study: StudySpec | None = Field(
        default=None,
        description="A Monte Carlo study of this mission (cptbt batch); command-line flags "
        "override it",
    )

    @model_validator(mode="after")
    def _cross_field(self, info: ValidationInfo) -> MissionBase:
        problems = self.problems()
        if not problems:
            return self
        sink = info.context.get("problems") if isinstance(info.context, dict) else None
        if isinstance(sink, list):  # the loader reports each problem at its own key's line
            sink.extend(problems)
            return self
        raise ValueError("; ".join(f"{dotted(loc)}: {msg}" for loc, msg in problems))

    # -- cross-field rules -------------------------------------------------------------------
    def advisories(self) -> list[Problem]:
        """What is valid but likely not what the mission means, as (key path, message): the
        CLI prints each as a warning at its key's line (:mod:`cptbt.advice`)."""
        from cptbt.advice import advisories

        return advisories(self)

    def problems(self) -> list[Problem]:
        """Every cross-field problem, as (key path, message); empty for a sound mission
        (:mod:`cptbt.mission_checks`)."""
        from cptbt.mission_checks import problems

        return problems(self)

    def commanded_speeds(self) -> list[tuple[Loc, float]]:
        """Every speed the mission commands, by key: the cruise speed, mission A's (if any)
        and each behaviour's own."""
        speeds: list[tuple[Loc, float]] = [(("speed_mps",), self.speed_mps)]
        if self.mission_a is not None:
            speeds.append((("mission_a", "speed_mps"), self.mission_a.speed_mps))
        for i, e in enumerate(self.entries()):
            if e.params.speed_mps is not None:
                speeds.append((("behaviours", i, e.family, "speed_mps"), e.params.speed_mps))
        return speeds

    # -- geometry --------------------------------------------------------------------------
    def corners_ne(self) -> list[tuple[float, float]]:
        """The OpArea corners in N-E metres (frames 'ne' and 'geodetic')."""
        corners = [(float(c[0]), float(c[1])) for c in self.op_area.corners]
        if self.frame == "geodetic":
            local = self.local_frame()
            assert local is not None
            return [local.to_ne(c[0], c[1]) for c in corners]
        return corners

    def op_area_geometry(self) -> OpArea:
        """The OpArea in the planning frame.

        Raises:
            ValueError: degenerate corners, or bearing/centre keys in frame 'planning'.
        """
        if self.frame != "planning":
            return OpArea.from_ne_corners(self.corners_ne(), self.op_area.x_axis_bearing_deg)
        if self.op_area.x_axis_bearing_deg is not None or self.op_area.geodetic_centre_deg:
            raise ValueError(
                "op_area.x_axis_bearing_deg and geodetic_centre_deg apply to frames 'ne' and "
                "'geodetic' only"
            )
        corners = [tuple(c) for c in self.op_area.corners]
        xs = sorted({c[0] for c in corners})
        ys = sorted({c[1] for c in corners})
        if len(xs) != 2 or len(ys) != 2:
            raise ValueError("in frame 'planning' the OpArea corners must form an axis-aligned box")
        return OpArea(xs[0], xs[1], ys[0], ys[1], PlanningFrame())

    def local_frame(self) -> LocalFrame | None:
        """The geodetic anchor of the N-E frame, if the mission has one."""
        centre = self.op_area.geodetic_centre_deg
        if centre is not None:
            return LocalFrame(GeoPoint(*centre))
        if self.frame == "geodetic":
            return LocalFrame.centred_on([tuple(c) for c in self.op_area.corners])  # type: ignore[misc]
        return None

    def to_xy(self, coord: Coord) -> Point:
        """A coordinate of this file in the planning frame."""
        if self.frame == "planning":
            return Point(float(coord[0]), float(coord[1]))
        if self.frame == "geodetic":
            local = self.local_frame()
            assert local is not None
            n, e = local.to_ne(coord[0], coord[1])
            return self.op_area_geometry().frame.ne_to_xy(n, e)
        return self.op_area_geometry().frame.ne_to_xy(coord[0], coord[1])

    def to_ne(self, p: Point) -> tuple[float, float]:
        """A planning-frame point as North-East metres about the OpArea centre."""
        return self.op_area_geometry().frame.xy_to_ne(p.x, p.y)

    def to_geodetic(self, p: Point) -> GeoPoint | None:
        """A planning-frame point as latitude/longitude, or None without a geodetic anchor."""
        local = self.local_frame()
        return None if local is None else local.to_geodetic(*self.to_ne(p))

    def entries(self) -> list[BehaviourEntry]:
        """The behaviour list, highest priority first."""
        return [BehaviourEntry.from_item(item) for item in self.behaviours]


def dotted(path: Loc) -> str:
    """A key path as written in messages: ``behaviours[2].maintain_plume.lambda_s``; a key
    that is not a plain word quoted with its control characters escaped (an attacker's key
    ``"evil\nkey\x1b[31m"`` split a problem over two lines, in red, and ``"/etc/passwd:1: x"``
    read as a problem in another file)."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
            continue
        word = str(part) if _WORD.fullmatch(str(part)) else repr(str(part))
        out += f".{word}" if out else word
    return out or "(top)"


_WORD = re.compile(r"[\w+.-]+")
"""A key written as it is in messages: letters, digits, ``_``, ``+`` (a joint sweep's), ``.``
(a sweep's path: a single key holding a dot reads as a nested path, as the sweep means it) and
``-``."""


def printable(text: str) -> str:
    """``text`` with its control and format characters and line breaks escaped (``\\x1b``,
    ``\\n``, ``\\u2028``): a message is one line, and carries no terminal codes from a file
    name or a key (an attacker's). Spaces of every kind stay (a file name with a no-break
    space is a name, not an attack)."""
    if text.isprintable():
        return text
    return "".join(repr(c)[1:-1] if unicodedata.category(c) in _ESCAPED else c for c in text)


_ESCAPED = ("Cc", "Cf", "Cs", "Zl", "Zp")
"""Unicode categories :func:`printable` escapes: controls, formats, lone surrogates (a name
not in UTF-8) and line and paragraph separators."""


class BehaviourEntry(BaseModel):
    """One validated behaviour of a mission."""

    model_config = ConfigDict(frozen=True)

    family: str
    variant: str
    params: BehaviourParams

    @classmethod
    def from_item(cls, item: Any) -> BehaviourEntry:
        """From a validated behaviour-list item (a model with exactly one family set)."""
        if isinstance(item, BehaviourEntry):
            return item
        ((family, params),) = ((k, v) for k, v in item if v is not None)
        return cls(family=family, variant=params.variant, params=params)

    @property
    def contract(self) -> Contract:
        """What this variant needs from the rest of the mission (from its registry spec)."""
        return getattr(type(self.params), "contract", None) or Contract()

    def to_data(self) -> dict[str, Any]:
        """The YAML form ``{family: {variant: ..., params...}}``.

        A parameter set to None where its default is not None (``upflow_check_m: null``: the
        check off) is kept as null: left out, it loaded back as the default, and every batch
        (which flies the mission as dumped) silently flew the default instead.
        """
        body = self.params.model_dump(mode="json")
        fields = type(self.params).model_fields
        body = {"variant": self.variant,
                **{k: v for k, v in body.items() if k != "variant"
                   and (v is not None or k not in fields or fields[k].default is not None)}}
        return {self.family: body}


def _variant_model(spec: BehaviourSpec) -> type[BehaviourParams]:
    name = "".join(p.title() for p in f"{spec.family}_{spec.variant}".split("_"))
    model = create_model(
        name,
        __base__=spec.params,
        __doc__=spec.summary or spec.params.__doc__,
        variant=(Literal[spec.variant], Field(default=spec.variant, description="Variant name")),  # type: ignore[arg-type]
    )
    model.contract = spec.contract
    return model


def _item_model(registry: Registry) -> type[BaseModel]:
    fields: dict[str, Any] = {}
    for family in registry.families():
        models = [_variant_model(s) for s in registry.variants(family)]
        if len(models) == 1:
            kind: Any = models[0]
        else:
            kind = Annotated[Union[tuple(models)], Field(discriminator="variant")]  # noqa: UP007
        fields[family] = (kind | None, None)
    default_variant = {f: registry.variants(f)[0].variant for f in registry.families()}

    def check(cls: type[BaseModel], data: Any) -> Any:
        if not isinstance(data, dict) or len(data) != 1:
            raise ValueError("each behaviour is one mapping 'family: {variant: ..., params}'")
        ((family, body),) = data.items()
        try:
            registry.get(str(family))
            if body is None:
                body = {}
            if isinstance(body, dict):
                body = {"variant": default_variant[family], **body}
                if not isinstance(body["variant"], str):
                    raise ValueError(f"{family}.variant must be a name")
                registry.get(family, body["variant"])
        except UnknownBehaviourError as exc:
            variant = body.get("variant") if isinstance(body, dict) else None
            removed = REMOVED_VARIANTS.get((str(family), str(variant)))
            msg = f"unknown variant {variant!r}: {removed}" if removed else str(exc)
            raise ValueError(msg) from None
        return {family: body}

    return create_model(
        "Behaviour",
        __config__=ConfigDict(frozen=True, extra="forbid"),
        __validators__={
            "_check": model_validator(mode="before")(check),  # type: ignore[dict-item]
        },
        **fields,
    )


@cache
def mission_model(
    registry: Registry, environment: type[BaseModel] | None = None
) -> type[MissionBase]:
    """The full mission model for a registry (and, in the application layer, an environment)."""
    item = _item_model(registry)
    about = "The simulated environment: preset, true source, flow (simulation only)"
    env: Any = (environment | None, Field(default=None, description=about)) if environment else (
        Any, Field(default=None, description=about))
    items: Any = list[item]  # type: ignore[valid-type]
    return create_model(
        "Mission",
        __base__=MissionBase,
        behaviours=(items, Field(min_length=1, description="Behaviours, highest priority first")),
        environment=env,
    )


def mission_to_data(mission: MissionBase) -> dict[str, Any]:
    """The mission as plain data that saves to equivalent YAML."""
    data = mission.model_dump(mode="json", exclude={"behaviours", "environment"})
    data["behaviours"] = [e.to_data() for e in mission.entries()]
    if mission.environment is not None:
        env = mission.environment
        data["environment"] = env.model_dump(mode="json") if isinstance(env, BaseModel) else env
    return data
