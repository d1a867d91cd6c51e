"""The mock's Problem answers (RFC 7807, every field of the ctrlX OpenAPI ``Problem`` schema).

``instance`` names what the problem is about: the NODE ADDRESS for anything
a node caused (``motion/axs/nope/state/values/actual/pos``, as real devices
send it and as clients such as Node-RED's ctrlX nodes match it to tell one bad
node from a broken subscription), otherwise the request path.

Diagnosis codes are 8 hex digits. ``detailedDiagnosisCode`` is the data
layer's own result code (``DLR_RESULT`` of the ctrlX SDK, e.g. ``80010001``
for DL_INVALID_ADDRESS); ``mainDiagnosisCode`` is the mock's: one for the data
layer, one for the identity manager. A real device answers from its own
diagnosis catalogue, so clients must not rely on the values, only on the shape.
"""

from __future__ import annotations

from typing import Any

from aiohttp import web

MAIN_DATALAYER, MAIN_IDENTITY = "080F0100", "080F0200"
"""The mock's main diagnosis codes (the first is the spec's own example)."""

RESULT_CODES: dict[str, str] = {
    "DL_FAILED": "80000001",
    "DL_INVALID_ADDRESS": "80010001",
    "DL_UNSUPPORTED": "80010002",
    "DL_TYPE_MISMATCH": "80010006",
    # The mock's historical title for "this node has no such method"; DL_UNSUPPORTED's code.
    "DL_INVALID_OPERATION": "80010002",
    "DL_INVALID_VALUE": "8001000D",
    "DL_ALREADY_EXISTS": "80010010",
    "DL_PERMISSION_DENIED": "80010014",
    "DL_MISSING_ARGUMENT": "80010016",
    "DL_RESOURCE_UNAVAILABLE": "80010018",
    "DL_SEC_NOTOKEN": "80070001",
    "DL_SEC_INVALIDSESSION": "80070002",
    "DL_SEC_UNAUTHORIZED": "80070004",
}
"""Data-layer result names and their ``DLR_RESULT`` values (ctrlX SDK), as 8 hex digits."""

STATUS_RESULTS: dict[int, str] = {
    400: "DL_INVALID_VALUE",
    401: "DL_SEC_UNAUTHORIZED",
    403: "DL_PERMISSION_DENIED",
    404: "DL_INVALID_ADDRESS",
    405: "DL_UNSUPPORTED",
    409: "DL_RESOURCE_UNAVAILABLE",
}
"""The result a Problem whose title is no result name falls back to, by HTTP status."""


def problem_body(
    status: int,
    title: str,
    detail: str,
    instance: str | None = None,
    *,
    dynamic: str = "",
    identity: bool = False,
) -> dict[str, Any]:
    """A Problem object with every field of the ctrlX ``Problem`` schema filled in."""
    result = title if title in RESULT_CODES else STATUS_RESULTS.get(status, "DL_FAILED")
    main = MAIN_IDENTITY if identity else MAIN_DATALAYER
    return {
        "type": "about:blank",
        "title": title,
        "status": status,
        "detail": detail,
        "instance": instance if instance is not None else "",
        "code": main,  # deprecated in the spec, still sent for older clients
        "mainDiagnosisCode": main,
        "detailedDiagnosisCode": RESULT_CODES[result],
        "dynamicDescription": dynamic,
        "severity": "Error",
        "links": [],
        "moreInfo": {"result": result},
        "cause": [],
    }


def problem(
    status: int,
    title: str,
    detail: str,
    instance: str | None = None,
    *,
    dynamic: str = "",
    identity: bool = False,
) -> web.Response:
    """A Problem response (``application/json``, the media type the ctrlX specs declare)."""
    body = problem_body(status, title, detail, instance, dynamic=dynamic, identity=identity)
    return web.json_response(body, status=status)


def request_problem(
    request: web.Request, status: int, title: str, detail: str, *, dynamic: str = ""
) -> web.Response:
    """A Problem about the request itself (no node): ``instance`` is the request path."""
    identity = request.path.startswith("/identity-manager/")
    return problem(status, title, detail, request.path, dynamic=dynamic, identity=identity)
