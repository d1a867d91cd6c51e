"""A ctrlX user's Python script built on ``requests``, run against the mock over HTTPS.

The script is written the way such scripts usually are: one ``requests.Session``
with the bearer token in its headers, plain JSON bodies, and the event stream
read with ``stream=True`` and ``iter_lines``. It runs in a thread (``requests``
is blocking) while the mock serves on a free loopback port.
"""

from __future__ import annotations

import asyncio
import json
import time
from pathlib import Path
from typing import Any

import requests

from server.ctrlx import unix_from_filetime
from tests.ctrlx.helpers import KIN12, running

NOPE = "motion/axs/nope/state/values/actual/pos"
DTEST = "plc/app/Application/sym/PLC_PRG/dTest"


def script(base: str, ca_file: str) -> dict[str, Any]:
    """Login, read, write, bulk, subscribe, read the stream, clean up; what it saw."""
    seen: dict[str, Any] = {}
    dl = f"{base}/automation/api/v2"
    with requests.Session() as s:
        # Without this, REQUESTS_CA_BUNDLE from the environment would win over s.verify.
        s.trust_env = False
        s.verify = ca_file
        r = s.post(
            f"{base}/identity-manager/api/v2/auth/token",
            json={"name": "boschrexroth", "password": "boschrexroth"},
            timeout=5,
        )
        r.raise_for_status()
        s.headers["Authorization"] = f"Bearer {r.json()['access_token']}"

        seen["read"] = s.get(f"{dl}/nodes/{KIN12[0]}", timeout=5).json()
        r = s.get(f"{dl}/nodes/{NOPE}", timeout=5)
        seen["missing"] = (r.status_code, r.headers["Content-Type"], r.json())
        seen["write"] = s.put(
            f"{dl}/nodes/{DTEST}", json={"type": "double", "value": 3.5}, timeout=5
        ).json()
        seen["read_back"] = s.get(f"{dl}/nodes/{DTEST}", timeout=5).json()["value"]
        seen["bulk"] = s.put(
            f"{dl}/bulk",
            params={"type": "read"},
            json=[{"address": n} for n in [*KIN12, NOPE]],
            timeout=5,
        ).json()

        props = {"id": "py-script", "publishInterval": 50, "errorInterval": 100}
        r = s.post(f"{dl}/events", json={"properties": props, "nodes": [*KIN12, NOPE]}, timeout=5)
        seen["created"] = r.status_code
        updates: dict[str, list[int]] = {}
        errors: list[dict[str, Any]] = []
        event = ""
        with s.get(
            f"{dl}/events/py-script",
            headers={"Accept": "text/event-stream"},
            stream=True,
            timeout=5,
        ) as r:
            seen["stream"] = (r.status_code, r.headers["Content-Type"])
            for line in r.iter_lines(decode_unicode=True):
                if line.startswith("event:"):
                    event = line.split(":", 1)[1].strip()
                elif line.startswith("data:"):
                    data = json.loads(line.split(":", 1)[1])
                    if event == "update":
                        updates.setdefault(data["node"], []).append(data["timestamp"])
                    elif event == "error":
                        errors.append(data)
                if errors and all(len(updates.get(n, [])) >= 3 for n in KIN12):
                    break
        seen["updates"], seen["errors"] = updates, errors
        seen["deleted"] = s.delete(f"{dl}/events/py-script", timeout=5).status_code
        seen["logout"] = s.delete(f"{base}/identity-manager/api/v2/auth/token", timeout=5)
        seen["after_logout"] = s.get(f"{dl}/nodes/{KIN12[0]}", timeout=5).status_code
    return seen


async def test_a_requests_script_reads_writes_bulks_and_subscribes(tmp_path: Path) -> None:
    async with running(tls_dir=tmp_path) as mock:
        assert mock.cert is not None
        seen = await asyncio.wait_for(
            asyncio.to_thread(script, mock.url, str(mock.cert.ca_file)), timeout=30
        )
    assert seen["read"]["type"] == "double" and isinstance(seen["read"]["value"], float)
    status, content_type, problem = seen["missing"]
    assert status == 404 and content_type.split(";")[0] == "application/json"
    assert problem["instance"] == NOPE and problem["title"] == "DL_INVALID_ADDRESS"
    assert seen["write"] == {"type": "double", "value": 3.5} and seen["read_back"] == 3.5
    assert [e["result"] for e in seen["bulk"]] == ["DL_OK", "DL_OK", "DL_INVALID_ADDRESS"]
    assert seen["bulk"][2]["value"]["instance"] == NOPE
    assert seen["created"] == 201
    assert seen["stream"] == (200, "text/event-stream")
    for node in KIN12:
        stamps = seen["updates"][node]
        assert stamps == sorted(stamps)
        assert abs(unix_from_filetime(stamps[-1]) - time.time()) < 5.0
    assert {e["instance"] for e in seen["errors"]} == {NOPE}
    assert seen["deleted"] == 200  # the script's stream was closed before it deleted
    assert seen["logout"].status_code == 204 and seen["after_logout"] == 401
