"""The mission file's JSON Schema, in the dialect editors understand (draft-07).

pydantic writes JSON Schema 2020-12 with OpenAPI's ``discriminator``; the YAML language servers
editors use (yaml-language-server in VS Code, JetBrains) read draft-07, where ``prefixItems``
means nothing and a ``discriminator`` is unknown. This module rewrites the schema into draft-07 —
fixed-length arrays as ``items: [...]``, ``$defs`` as ``definitions``, ``anyOf`` for the behaviour
variants — and adds a ``$schema`` and a title. Cross-field rules (a rectangular OpArea, places
inside it, vehicle limits, behaviour contracts) cannot be said in JSON Schema: ``cptbt validate``
checks them.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from cptbt.mission import mission_model
from cptbt.registry import Registry

DRAFT_07 = "http://json-schema.org/draft-07/schema#"


def mission_json_schema(
    registry: Registry, environment: type[BaseModel] | None = None
) -> dict[str, Any]:
    """The JSON Schema (draft-07) of mission files for a registry and environment model."""
    raw = mission_model(registry, environment).model_json_schema()
    schema = _draft07(raw)
    schema["definitions"] = schema.pop("$defs", {})
    return {
        "$schema": DRAFT_07,
        "title": "cptbt mission",
        "description": "A cptbt chemical plume tracing mission (cptbt validate checks the "
        "cross-field rules this schema cannot express)",
        **{k: v for k, v in schema.items() if k not in ("title", "description")},
    }


def partial_schema(model: type[BaseModel]) -> dict[str, Any]:
    """The schema of a partial override of ``model``: its fields, none required, no others."""
    schema = _draft07(model.model_json_schema())
    schema.pop("required", None)
    schema.pop("title", None)
    schema["additionalProperties"] = False
    return schema


def _draft07(node: Any) -> Any:
    if isinstance(node, list):
        return [_draft07(n) for n in node]
    if not isinstance(node, dict):
        return node
    out: dict[str, Any] = {}
    for key, value in node.items():
        if key == "discriminator":
            continue
        if key == "prefixItems":
            out["items"] = _draft07(value)
            out["additionalItems"] = False
        elif key == "oneOf":
            out["anyOf"] = _draft07(value)
        elif key == "$ref" and isinstance(value, str):
            out[key] = value.replace("#/$defs/", "#/definitions/")
        elif key in ("properties", "$defs", "definitions"):
            out[key] = {name: _draft07(v) for name, v in value.items()}
        else:
            out[key] = _draft07(value)
    return out
