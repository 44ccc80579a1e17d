"""The behaviour registry: behaviours are found by (family, variant) name, registered as data.

Built-in behaviours, and any third-party package's, are declared in the entry-point group
``cptbt.behaviours``; each entry point names an iterable of :class:`BehaviourSpec` or
:class:`~cptbt.node.PlanBehaviour` subclasses. The core never imports the behaviours itself.
"""

from __future__ import annotations

import difflib
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from importlib.metadata import EntryPoint, entry_points

import py_trees
from pydantic import ValidationError

from cptbt.node import BehaviourParams, Contract, PlanBehaviour

log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "cptbt.behaviours"

#: The behaviour slots of TRO Fig. 2, in their default priority (SPEC §3).
FAMILIES: tuple[str, ...] = (
    "safety",
    "declare_source",
    "maintain_plume",
    "reacquire_plume",
    "find_plume",
    "return_home",
    "move_to_field",
)

Builder = Callable[[BehaviourParams, str], py_trees.behaviour.Behaviour]


class RegistryError(Exception):
    """Base of the registry's errors."""


class UnknownBehaviourError(RegistryError, KeyError):
    """No behaviour under that name; the message lists the close matches."""

    def __str__(self) -> str:
        return str(self.args[0])


class DuplicateBehaviourError(RegistryError):
    """Two registrations under one (family, variant)."""


@dataclass(frozen=True)
class BehaviourSpec:
    """One registered variant.

    Attributes:
        family: the slot it fills; one of :data:`FAMILIES` or a new family of a plug-in.
        variant: its name within the family.
        params: its frozen parameter model (the YAML schema of its mission entry).
        build: makes the node (or sub-tree) from validated params and a blackboard namespace.
        summary: one line for listings.
        behaviour_classes: the PlanBehaviour classes the node is made of (for conformance checks).
        default: the variant used when a mission names the family without a variant.
        contract: what it needs from the rest of the mission (checked by ``validate``, so
            nothing that validates fails at set-up).
    """

    family: str
    variant: str
    params: type[BehaviourParams]
    build: Builder
    summary: str = ""
    behaviour_classes: tuple[type[PlanBehaviour], ...] = field(default=())
    default: bool = False
    contract: Contract = field(default_factory=Contract)

    @property
    def key(self) -> str:
        """``family.variant``."""
        return f"{self.family}.{self.variant}"

    @classmethod
    def of(cls, behaviour: type[PlanBehaviour], *, default: bool = False) -> BehaviourSpec:
        """The spec of a single-leaf behaviour class."""

        def build(params: BehaviourParams, namespace: str) -> PlanBehaviour:
            return behaviour(params, namespace=namespace)

        return cls(
            family=behaviour.family,
            variant=behaviour.variant,
            params=behaviour.Params,
            build=build,
            summary=_first_line(behaviour.__doc__),
            behaviour_classes=(behaviour,),
            default=default,
            contract=behaviour.contract,
        )


def _first_line(doc: str | None) -> str:
    return (doc or "").strip().splitlines()[0] if doc and doc.strip() else ""


class Registry:
    """Behaviour variants by (family, variant)."""

    def __init__(self) -> None:
        self._specs: dict[tuple[str, str], BehaviourSpec] = {}
        self.broken: list[str] = []  # entry points that could not be loaded, and why

    def register(self, item: BehaviourSpec | type[PlanBehaviour]) -> BehaviourSpec:
        """Add one variant.

        Raises:
            DuplicateBehaviourError: the (family, variant) is taken.
            RegistryError: the item is neither a :class:`BehaviourSpec` nor a
                :class:`~cptbt.node.PlanBehaviour` subclass.
        """
        if not isinstance(item, BehaviourSpec) and not (
                isinstance(item, type) and issubclass(item, PlanBehaviour)):
            raise RegistryError(f"{item!r} is neither a PlanBehaviour subclass nor a "
                                "BehaviourSpec")
        if isinstance(item, type) and not (item.family and item.variant):
            # its name, not a dataclass repr of the spec (a review: 443 characters of it)
            raise RegistryError(f"{item.__module__}.{item.__qualname__} has no family or "
                                "variant name: set its ClassVars family and variant")
        spec = item if isinstance(item, BehaviourSpec) else BehaviourSpec.of(item)
        if not spec.family or not spec.variant:
            raise RegistryError(f"the BehaviourSpec {spec.summary or spec.params.__name__!r} "
                                "has no family or variant name")
        check_params(spec)
        key = (spec.family, spec.variant)
        if key in self._specs:
            raise DuplicateBehaviourError(f"behaviour {spec.key} is registered twice")
        self._specs[key] = spec
        return spec

    def register_all(self, items: Iterable[BehaviourSpec | type[PlanBehaviour]]) -> None:
        """Add several variants."""
        for item in items:
            self.register(item)

    def families(self) -> list[str]:
        """Family names: the TRO slots first, in priority order, then plug-in families."""
        present = {f for f, _ in self._specs}
        return [f for f in FAMILIES if f in present] + sorted(present - set(FAMILIES))

    def variants(self, family: str) -> list[BehaviourSpec]:
        """The specs of one family, the default first."""
        specs = [s for (f, _), s in self._specs.items() if f == family]
        return sorted(specs, key=lambda s: (not s.default, s.variant))

    def specs(self) -> list[BehaviourSpec]:
        """Every spec, grouped by family."""
        return [s for f in self.families() for s in self.variants(f)]

    def get(self, family: str, variant: str | None = None) -> BehaviourSpec:
        """Look up a variant (the family's default when ``variant`` is None).

        Raises:
            UnknownBehaviourError: no such family or variant; the message lists close matches.
        """
        families = self.families()
        broken = (f" (not loaded: {'; '.join(self.broken)})" if self.broken else "")
        if family not in families:
            raise UnknownBehaviourError(f"unknown behaviour {family!r}{_close(family, families)}"
                                        + broken)
        variants = self.variants(family)
        if variant is None:
            return variants[0]
        spec = self._specs.get((family, variant))
        if spec is None:
            elsewhere = sorted(f for (f, v) in self._specs if v == variant)
            if elsewhere:  # a plug-in registered it under another (perhaps misspelt) family
                raise UnknownBehaviourError(
                    f"unknown variant {variant!r} of {family}: {variant!r} is registered "
                    f"under the family {' and '.join(repr(f) for f in elsewhere)}"
                    + (", a plug-in's own family" if set(elsewhere) - set(FAMILIES) else "")
                    + (" (misspelt?)" if difflib.get_close_matches(family, elsewhere, 1, 0.8)
                       else "")
                )
            close = _close(variant, [s.variant for s in variants])
            raise UnknownBehaviourError(
                f"unknown variant {variant!r} of {family}{close}"
                # a plug-in's, not installed here or not listed (a review): say how it is found
                + ("" if "did you mean" in close else
                   f" (a plug-in's? its package lists it in an entry point of the group "
                   f"{ENTRY_POINT_GROUP!r} and is installed here: pip install -e PACKAGE)")
                + broken
            )
        return spec



    def __len__(self) -> int:
        return len(self._specs)


def package_of(spec: BehaviourSpec) -> str:
    """The top-level package a registered variant comes from (``cptbt`` for the built-in)."""
    for obj in (*spec.behaviour_classes, spec.build):
        top = (getattr(obj, "__module__", None) or "").split(".")[0]
        if top and top != "cptbt":
            return top
    return "cptbt"


def plugin_provenance(pairs: Iterable[tuple[str, str]],
                      registry: Registry | None = None) -> dict[str, str]:
    """``family.variant`` → ``package version`` for each of ``pairs`` a plug-in supplies (the
    built-in left out): what a study's ``study.json`` records, so that its folder names the
    code that made it (a review: a shared folder did not say which plug-in flew its variant,
    and "install the plug-in it came from" could not name it)."""
    from importlib.metadata import PackageNotFoundError, packages_distributions, version

    registry = registry or default_registry()
    dists = packages_distributions()
    out: dict[str, str] = {}
    for family, variant in sorted(set(pairs)):
        try:
            package = package_of(registry.get(family, variant))
        except RegistryError:
            continue
        if package == "cptbt":
            continue
        dist = (dists.get(package) or [package])[0]
        try:
            out[f"{family}.{variant}"] = f"{dist} {version(dist)}"
        except PackageNotFoundError:
            out[f"{family}.{variant}"] = package
    return out


def misspelt_slot(family: str) -> str | None:
    """The TRO slot a plug-in family's name is one slip from (``reaquire_plume``:
    ``reacquire_plume``), or None: a new family is allowed, but a misspelt slot is not what its
    author meant, and the tree does not give it the slot's place."""
    if family in FAMILIES:
        return None
    match = difflib.get_close_matches(family, FAMILIES, 1, 0.85)
    return match[0] if match else None


def _close(word: str, choices: list[str]) -> str:
    matches = difflib.get_close_matches(word, choices, n=3, cutoff=0.5)
    if matches:
        return "; did you mean " + " or ".join(repr(m) for m in matches) + "?"
    return "; known: " + ", ".join(choices)


_DEFAULT: Registry | None = None


def load_entry_points(group: str = ENTRY_POINT_GROUP) -> Registry:
    """A new registry holding every variant declared in the entry-point group.

    The built-in entry points are read first. A plug-in's entry point that cannot be loaded,
    holds something that is not a behaviour, or takes a name already registered (a built-in's,
    another plug-in's, or its own twice) is left out whole, warned of and kept in
    :attr:`Registry.broken`: it blocks only its own variants (a review's plug-in reusing a
    built-in's name had stopped every command, the shipped missions' too), and a mission that
    names one of them is told why it is missing.

    Raises:
        RegistryError: a built-in entry point is at fault (an installation problem).
    """
    registry = Registry()
    origin: dict[tuple[str, str], str] = {}
    # the built-in first: a plug-in can never take a built-in's name, whatever its entry
    # point's name sorts as (a review's sorted before the built-in's)
    for ep in sorted(entry_points(group=group), key=lambda e: (not _builtin(e.value), e.name)):
        try:
            specs = _entry_point_specs(ep, registry, origin)
        except Exception as exc:
            if _builtin(ep.value):
                raise
            said = (str(exc) if isinstance(exc, RegistryError)
                    else f"entry point {ep.value}: {type(exc).__name__}: {exc}")
            registry.broken.append(said)
            if isinstance(exc, _Clash):  # two plug-ins: neither's is flown (a diff review's
                # mission flew whichever entry point's name sorted first, validated "ok")
                registry._specs.pop(exc.key, None)
                log.warning("plug-in behaviour %s left out: %s (entry point %s is not loaded, "
                            "and %s's %s is withdrawn)", ".".join(exc.key), said, ep.value,
                            exc.first, ".".join(exc.key))
            else:
                log.warning("plug-in behaviours left out: %s (none of its variants is "
                            "available)", said)
            continue
        for spec in specs:
            registry.register(spec)
            origin[(spec.family, spec.variant)] = ep.value
    return registry


class _Clash(RegistryError):
    """Two plug-ins' entry points register one (family, variant) (``first`` read first)."""

    def __init__(self, message: str, key: tuple[str, str], first: str) -> None:
        super().__init__(message)
        self.key, self.first = key, first


def _entry_point_specs(ep: EntryPoint, registry: Registry,
                       origin: dict[tuple[str, str], str]) -> list[BehaviourSpec]:
    """The variants one entry point declares, checked as a whole against ``registry`` (which
    ``origin`` says where each came from) before any is registered.

    Raises:
        RegistryError: an item is not a behaviour, or a name is taken (the message names the
            entry points).
        Exception: the entry point's object cannot be imported.
    """
    items = ep.load()
    if isinstance(items, type) or not isinstance(items, Iterable):
        raise RegistryError(
            f"entry point {ep.value}: expected a tuple or list of PlanBehaviour subclasses "
            f"or BehaviourSpecs, got {getattr(items, '__name__', type(items).__name__)!r}"
            + (f" (write ({items.__name__},))" if isinstance(items, type) else ""))
    staged = Registry()
    try:  # a review's bad item and reused name read as an internal error, or no source
        for item in items:
            staged.register(item)
    except DuplicateBehaviourError:
        family, variant = _key_of(item)
        raise RegistryError(f"entry point {ep.value} registers {family}.{variant} twice"
                            ) from None
    except (RegistryError, TypeError) as exc:
        raise RegistryError(f"entry point {ep.value}: {exc}") from exc
    for spec in staged.specs():
        first = origin.get((spec.family, spec.variant))
        if first is not None and _builtin(first) and not _builtin(ep.value):
            raise RegistryError(
                f"entry point {ep.value} registers {spec.key}, a built-in's name "
                f"(cptbt's {first}): give the plug-in's variant a name of its own")
        if first is not None:
            raise _Clash(f"behaviour {spec.key} is registered by both entry point {first} "
                         f"and {ep.value}: rename one", (spec.family, spec.variant), first)
    return staged.specs()


def check_params(spec: BehaviourSpec) -> None:
    """A variant's ``Params``: a :class:`~cptbt.node.BehaviourParams` whose defaults pass its
    own rules. A plain pydantic model had registered and then read as a fault of the mission's
    line 3, and a default of -5 under ``gt=0`` flew (a plug-in author's review)."""
    where = f"{spec.family}.{spec.variant}"
    params = spec.params
    if not (isinstance(params, type) and issubclass(params, BehaviourParams)):
        raise RegistryError(f"{where}: its Params ({getattr(params, '__name__', params)!r}) is "
                            "not a cptbt.node.BehaviourParams subclass: derive it from one")
    for cls in spec.behaviour_classes:
        _check_inherited_params(where, cls, cls.Params)
    # by the key the model reads (an alias: validated by name, a plug-in's aliased field had
    # been refused as an extra key, a diff review)
    given = {(f.validation_alias if isinstance(f.validation_alias, str) else f.alias or name):
             f.default for name, f in params.model_fields.items()
             if not f.is_required() and f.default_factory is None}
    try:
        params.model_validate(given)
    except ValidationError as exc:
        errors = [e for e in exc.errors(include_url=False) if e["type"] != "missing"]
        if not errors:  # only the required fields missing: they are the mission's to give
            return
        err = errors[0]
        field = ".".join(str(x) for x in err["loc"])
        raise RegistryError(f"{where}: the default of {field} ({given.get(field)!r}) breaks its "
                            f"own rule: {err['msg']}") from None
    except Exception:  # a model validator that needs the required fields: judged when given
        pass


def _check_inherited_params(where: str, cls: type[PlanBehaviour], params: type) -> None:
    """A behaviour's ``Params`` must keep the settings of the base it subclasses: the base's own
    code reads them (a plug-in author's declaration rule derived its Params from
    ``BehaviourParams``, validated, and failed at its declaration for want of
    ``source_radius_m``, which ``SourceDeclaration.decide`` reads)."""
    for base in cls.__mro__[1:]:
        wanted = base.__dict__.get("Params")
        if wanted is None or not (isinstance(base, type) and issubclass(base, PlanBehaviour)):
            continue
        if isinstance(params, type) and not issubclass(params, wanted):
            raise RegistryError(
                f"{where}: its Params ({getattr(params, '__name__', params)!r}) does not derive "
                f"from {wanted.__module__}.{wanted.__qualname__}, the Params of "
                f"{base.__module__}.{base.__qualname__} it subclasses (whose code reads its "
                "settings): derive it from that")
        # every base that names Params, not the nearest alone: a class of two behaviours'
        # had passed with the Params of one (an attacker's)


def _builtin(entry_point_value: str) -> bool:
    """Whether an entry point's object is cptbt's own (``cptbt.behaviours...:BEHAVIOURS``)."""
    return entry_point_value.split(":")[0].split(".")[0] == "cptbt"


def _key_of(item: object) -> tuple[str, str]:
    """The (family, variant) an item registers under (empty names if it has none)."""
    return (str(getattr(item, "family", "")), str(getattr(item, "variant", "")))


def default_registry() -> Registry:
    """The registry of the installed entry points (loaded once)."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = load_entry_points()
    return _DEFAULT
