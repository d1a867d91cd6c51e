"""The vendored ctrlX OpenAPI descriptions, loaded with their errata, and validators for them.

The descriptions are vendored, unmodified, in ``tests/specs/ctrlx`` (see its ORIGIN.md).
Where a description contradicts itself, the smallest correction is applied
to the loaded document (``_errata``); a test proves each one is needed.
"""

from __future__ import annotations

import copy
import json
import warnings
from pathlib import Path
from typing import Any

from openapi_core import Config, OpenAPI
from openapi_core.testing import MockRequest
from openapi_schema_validator import OAS30Validator

SPECS = Path(__file__).resolve().parent.parent / "specs" / "ctrlx"
DL_FILE, IM_FILE = "datalayer.v2.1.5.openapi.json", "identitymanager.v2.10.0.openapi.json"
DL, IM = "/automation/api/v2", "/identity-manager/api/v2"
NODE = DL + "/nodes/{Path}"


def _load(name: str) -> dict[str, Any]:
    path = SPECS / name
    assert path.is_file(), f"the ctrlX OpenAPI description {path} is missing"
    document: dict[str, Any] = json.loads(path.read_text())
    return document


RAW_DL = _load(DL_FILE)
RAW_IM = _load(IM_FILE)


VALUE_SCHEMAS: dict[str, dict[str, Any]] = {
    "bool8": {"type": "boolean"},
    **{t: {"type": "integer"} for t in ("int8", "uint8", "int16", "uint16", "int32", "uint32")},
    "float": {"type": "number"},
    "double": {"type": "number"},
    "string": {"type": "string"},
    "arbool8": {"type": "array", "items": {"type": "boolean"}},
    **{
        t: {"type": "array", "items": {"type": "integer"}}
        for t in ("arint8", "aruint8", "arint16", "aruint16", "arint32", "aruint32")
        + ("arint64", "aruint64")
    },
    "arfloat32": {"type": "array", "items": {"type": "number"}},
    "arfloat64": {"type": "array", "items": {"type": "number"}},
    "arstring": {"type": "array", "items": {"type": "string"}},
    "raw": {"type": "string"},
    "object": {"type": "object"},
    "timestamp": {"type": "integer"},
    "artimestamp": {"type": "array", "items": {"type": "integer"}},
    "empty": {},
}
"""The JSON form of a value of each data-layer type (``Data.type``'s enum, in full)."""


def _typed_value(schema: dict[str, Any], published: dict[str, Any] | None = None) -> None:
    """Check ``value`` by the ``type`` beside it: one alternative per JSON form.

    The published ``value`` type still holds where it fits: ``object`` for
    ``type: object`` in Data, and (``published``) for events without a ``type``,
    as keepalives are. Only the other types get the JSON form of their values.
    """
    value = schema["properties"]["value"]
    forms: dict[str, list[str]] = {}
    for kind, form in VALUE_SCHEMAS.items():
        forms.setdefault(repr(form), []).append(kind)
    alternatives = [
        {
            "required": ["type"],
            "properties": {"type": {"enum": kinds}, "value": VALUE_SCHEMAS[kinds[0]]},
        }
        for kinds in forms.values()
    ]
    if published is not None:
        alternatives.append({"not": {"required": ["type"]}, "properties": {"value": published}})
    schema["properties"]["value"] = {"description": value["description"]}
    schema["oneOf"] = alternatives


def _errata(document: dict[str, Any]) -> dict[str, Any]:
    """The data-layer description with its self-contradictions corrected.

    * ``Data.value`` says ``type: object``, yet the description's own Data
      example holds a string, and a double node holds a number: a value is
      checked by the ``type`` beside it (``VALUE_SCHEMAS``; ``object`` stays ``object``).
    * ``SSE_EventData.value`` says ``type: string``, yet the description's own
      event-stream example holds objects: the same, by the event's ``type``
      (events without one, keepalives, keep the published ``string``).
    * ReadNode's 200 is ``oneOf`` Data, MetaData and BrowseData, yet every
      browse and metadata answer is a Data too (and MetaData's ``metadata`` says
      no ``type: object``, so any value fits it): ``anyOf``, with ``metadata``
      an object. Which of them a read must be is checked by its query
      (test_mock_conformance).
    * ReadNode's query parameter ``type`` has ``default: 'null'``, outside its
      own enum (so a read without ``?type=`` would count as invalid).
    * GetCreatedSubscription lists no 404, yet the description says an unused
      subscription "will be deleted automatically" within a minute, and the
      DELETE and PUT of the very same path answer 404 for an unknown one.
    """
    fixed = copy.deepcopy(document)
    del _read_type_parameter(fixed)["schema"]["default"]
    one = fixed["paths"]["/events/{SubscriptionName}"]
    one["get"]["responses"]["404"] = copy.deepcopy(one["delete"]["responses"]["404"])
    schemas = fixed["components"]["schemas"]
    assert set(VALUE_SCHEMAS) == set(schemas["Data"]["properties"]["type"]["enum"])
    _typed_value(schemas["Data"])
    _typed_value(schemas["SSE_EventData"], schemas["SSE_EventData"]["properties"]["value"])
    read = _read_node_ok(fixed)
    read["anyOf"] = read.pop("oneOf")
    schemas["metadata"]["type"] = "object"
    return fixed


def _read_node_ok(document: dict[str, Any]) -> dict[str, Any]:
    """The schema of ReadNode's JSON 200."""
    ok = document["paths"]["/nodes/{Path}"]["get"]["responses"]["200"]
    schema: dict[str, Any] = ok["content"]["application/json"]["schema"]
    return schema


def parse_event_stream(raw: bytes) -> list[dict[str, Any]]:
    """A ``text/event-stream`` body as the SSE_Event items its description shows.

    Written from the HTML standard's event-stream format (fields, a blank line
    ends an event, data lines joined), not from linkview's own parser; ``data``
    is JSON, ``id`` a number, as SSE_Event says. A trailing unfinished event is left out.
    """
    events, fields, data = [], {}, []
    for line in raw.decode().split("\n"):
        line = line.removesuffix("\r")
        if not line:
            if data:
                envelope = {"data": json.loads("\n".join(data)), **fields}
                events.append(envelope)
            fields, data = {}, []
            continue
        name, _, value = line.partition(":")
        value = value.removeprefix(" ")
        if name == "data":
            data.append(value)
        elif name == "event":
            fields["event"] = value
        elif name == "id":
            fields["id"] = float(value)
    return events


def _read_type_parameter(document: dict[str, Any]) -> dict[str, Any]:
    parameters = document["paths"]["/nodes/{Path}"]["get"]["parameters"]
    found: dict[str, Any] = next(p for p in parameters if p["name"] == "type")
    return found


FIXED_DL = _errata(RAW_DL)
# The data-layer description fails its own meta-schema ("default: 'null'" outside its
# enum), so openapi-core's check of the description itself is switched off.
CONFIG = Config(
    spec_validator_cls=None,
    extra_media_type_deserializers={"text/event-stream": parse_event_stream},
)
DL_API = OpenAPI.from_dict(FIXED_DL, config=CONFIG)
IM_API = OpenAPI.from_dict(copy.deepcopy(RAW_IM), config=CONFIG)


def check_request(api: OpenAPI, request: MockRequest) -> None:
    """Validate a request we sent (bearer security included)."""
    with warnings.catch_warnings():
        # openapi-core cannot evaluate the oauth2 alternative of the security list.
        warnings.filterwarnings("ignore", "Unsupported scheme type", UserWarning)
        api.validate_request(request)


def component(document: dict[str, Any], name: str) -> OAS30Validator:
    """A validator for ``#/components/schemas/<name>`` of ``document``."""
    root = {"$ref": f"#/components/schemas/{name}", "components": document["components"]}
    return OAS30Validator(root)
