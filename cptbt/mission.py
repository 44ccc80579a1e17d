"""The mission file: one pydantic model, validated once at the door (STYLE 7).

A mission's behaviour list is checked against the registry: each entry is ``family: {variant:
name, <params>}`` and its params are validated by that variant's own frozen model. The full model
is built per registry (and per simulator environment model, which only the application layer
knows), so ``cptbt schema`` can print a JSON Schema that covers every installed variant.
"""

from __future__ import annotations

from functools import cache
from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, create_model, field_validator, model_validator

from cptbt.frames import OpArea, PlanningFrame
from cptbt.geodesy import GeoPoint, LocalFrame
from cptbt.mission_a import MissionASpec
from cptbt.node import BehaviourParams
from cptbt.registry import BehaviourSpec, Registry, UnknownBehaviourError
from cptbt.types import Point

Coord = tuple[float, float]


class OpAreaSpec(BaseModel):
    """The OpArea as written: four corners in the mission's frame."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    corners: list[Coord] = Field(
        min_length=4, max_length=4, description="Four corners, [a, b] each, in the mission frame"
    )
    x_axis_bearing_deg: float | None = Field(
        default=None,
        description="Compass bearing of the planning +x axis (default: along the long side, "
        "bearing in [0, 180)); only for frames 'ne' and 'geodetic'",
    )
    geodetic_centre_deg: Coord | None = Field(
        default=None,
        description="[latitude, longitude] (decimal degrees, WGS-84) of the N-E origin, the "
        "OpArea centre. Frame 'geodetic': default is the corners' centre; frame 'ne': optional, "
        "lets outputs report latitude/longitude",
    )


class MissionBase(BaseModel):
    """Fields every mission has; :func:`mission_model` adds the behaviour list's schema."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = Field(min_length=1, description="Mission identifier")
    description: str = ""
    frame: Literal["ne", "planning", "geodetic"] = Field(
        default="ne",
        description="Frame of every coordinate in this file: 'ne' = [north, east] metres; "
        "'planning' = [x, y] metres of an OpArea aligned with x = north; 'geodetic' = "
        "[latitude, longitude] decimal degrees (WGS-84)",
    )
    op_area: OpAreaSpec
    home: Coord = Field(description="Where the vehicle goes after declaring, in the mission frame")
    start: Coord | None = Field(
        default=None, description="Move-to-field goal and the vehicle's starting point"
    )
    speed_mps: float = Field(default=1.5, gt=0, description="Cruise speed command, m/s")
    cycle_hz: float = Field(default=1.0, gt=0, le=100, description="Planner cycle rate, Hz")
    threshold: float = Field(default=0.20, ge=0, description="Detection threshold (TRO Table I)")
    flow_window_s: float = Field(default=100.0, gt=0, description="Flow averaging window, s")
    time_limit_s: float = Field(default=3600.0, gt=0, description="AMP time limit, s")
    behaviours: list[Any] = Field(min_length=1, description="Behaviours, highest priority first")
    environment: Any = Field(default=None, description="Simulated environment (simulator only)")
    mission_a: MissionASpec | None = Field(
        default=None,
        description="The vehicle's own pre-programmed mission and when the AMP takes over "
        "(SPEC §9); without it the AMP drives from t = 0",
    )

    @field_validator("op_area")
    @classmethod
    def _area_not_degenerate(cls, v: OpAreaSpec) -> OpAreaSpec:
        if len({tuple(c) for c in v.corners}) != 4:
            raise ValueError("the four corners must be distinct")
        return v

    @model_validator(mode="after")
    def _geometry(self) -> MissionBase:
        self.op_area_geometry()  # raises ValueError on a degenerate or non-rectangular area
        families = [e.family for e in self.entries()]
        seen = {f for f in families if families.count(f) > 1}
        if seen:
            raise ValueError(f"behaviour listed twice: {', '.join(sorted(seen))}")
        return self

    def op_area_geometry(self) -> OpArea:
        """The OpArea in the planning frame."""
        corners = [tuple(c) for c in self.op_area.corners]
        if self.frame == "geodetic":
            local = self.local_frame()
            assert local is not None
            ne = [local.to_ne(c[0], c[1]) for c in corners]
            return OpArea.from_ne_corners(ne, self.op_area.x_axis_bearing_deg)
        if self.frame == "ne":
            return OpArea.from_ne_corners(corners, self.op_area.x_axis_bearing_deg)  # type: ignore[arg-type]
        if self.op_area.x_axis_bearing_deg is not None or self.op_area.geodetic_centre_deg:
            raise ValueError(
                "op_area.x_axis_bearing_deg and geodetic_centre_deg apply to frames 'ne' and "
                "'geodetic' only"
            )
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

    def to_data(self) -> dict[str, Any]:
        """The YAML form ``{family: {variant: ..., params...}}``."""
        body = self.params.model_dump(mode="json", exclude_none=True)
        body = {"variant": self.variant, **{k: v for k, v in body.items() if k != "variant"}}
        return {self.family: body}


def _variant_model(spec: BehaviourSpec) -> type[BehaviourParams]:
    name = "".join(p.title() for p in f"{spec.family}_{spec.variant}".split("_"))
    return create_model(
        name,
        __base__=spec.params,
        __doc__=spec.summary or spec.params.__doc__,
        variant=(Literal[spec.variant], Field(default=spec.variant, description="Variant name")),  # type: ignore[arg-type]
    )


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
                registry.get(family, body["variant"])
        except UnknownBehaviourError as exc:
            raise ValueError(str(exc)) from None
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
    env: Any = (environment, Field(default_factory=environment)) if environment else (Any, None)
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
