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


def _errata(document: dict[str, Any]) -> dict[str, Any]:
    """The data-layer description with its self-contradictions corrected.

    * ``Data.value`` says ``type: object``, yet the description's own Data
      example holds a string, and a double node holds a number.
    * ``SSE_EventData.value`` says ``type: string``, yet the description's own
      event-stream example holds objects.
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
    del schemas["Data"]["properties"]["value"]["type"]
    del schemas["SSE_EventData"]["properties"]["value"]["type"]
    return fixed


def _read_type_parameter(document: dict[str, Any]) -> dict[str, Any]:
    parameters = document["paths"]["/nodes/{Path}"]["get"]["parameters"]
    found: dict[str, Any] = next(p for p in parameters if p["name"] == "type")
    return found


FIXED_DL = _errata(RAW_DL)
# The data-layer description fails its own meta-schema ("default: 'null'" outside its
# enum), so openapi-core's check of the description itself is switched off.
CONFIG = Config(spec_validator_cls=None)
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
