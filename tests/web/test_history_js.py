"""The page's history-window decoder (static/js/history.js, under node) agrees with the server's."""

from __future__ import annotations

import base64
import dataclasses
import json
import math
import shutil
import subprocess
from typing import Any

import numpy as np

from server.ctrlx import DataLayerError, Sample
from server.history import History, decode_binary, encode_binary, source_window
from server.kinematics import Type12
from tests.conftest import demo_cell
from tests.web._browser import ROOT

MODULE = ROOT / "static" / "js" / "history.js"
NODE = shutil.which("node")
SCRIPT = """
import { decodeWindow, lastAtOrBefore } from %s;
let input = '';
for await (const chunk of process.stdin) input += chunk;
const bytes = Buffer.from(JSON.parse(input), 'base64');
const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length);
const w = decodeWindow(buffer);
const list = (a) => a === null ? null : Array.from(a, (v) => Number.isNaN(v) ? 'NaN' : v);
process.stdout.write(JSON.stringify({
  count: w.count, t: list(w.t), seq: list(w.seq),
  at: [lastAtOrBefore(w.t, w.t[3]), lastAtOrBefore(w.t, w.t[3] - 1e-4), lastAtOrBefore(w.t, 0)],
  robots: w.robots.map((r) => ({ name: r.name, index: r.index, jointCount: r.jointCount,
    linkCount: r.linkCount, ok: list(r.ok), joints: list(r.joints), tcp: list(r.tcp),
    links: list(r.links), errors: r.errors })),
}));
"""


def decode_in_node(data: bytes) -> dict[str, Any]:
    assert NODE is not None, "node is missing: apt-get install nodejs"
    done = subprocess.run(
        [NODE, "--input-type=module", "-e", SCRIPT % json.dumps(MODULE.as_uri())],
        input=json.dumps(base64.b64encode(data).decode()),
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    result: dict[str, Any] = json.loads(done.stdout)
    return result


def as_floats(values: list[Any]) -> np.ndarray:
    return np.array([math.nan if v == "NaN" else v for v in values], dtype=float)


def test_node_decodes_a_window_as_the_server_encoded_it() -> None:
    cell = demo_cell()
    nodes = [n for r in cell.robots for n in r.nodes]
    history = History(seconds=10.0)
    source = history.source("demo", nodes, 0.02)
    for k in range(12):  # one sample with an unreadable node
        values: dict[str, float | Exception] = {n: 10.0 for n in nodes}
        if k == 5:
            values[cell.robots[1].nodes[2]] = DataLayerError("404")
        source.sample(k + 1, Sample(100.0 + 0.02 * k, values))
    rows = source.ring.rows(0)
    # A five-bar whose L4 is far too short closes at no angle: every posture unreachable.
    broken = dataclasses.replace(cell.robots[0], kinematics=Type12(l4=0.01))
    robots = list(enumerate([broken, *cell.robots[1:]]))
    windows = source_window(robots, rows, source.ring.column, "links")
    data = encode_binary("demo", 100.0, 101.0, rows, windows, "links")
    ours = decode_binary(data)
    theirs = decode_in_node(data)
    assert theirs["count"] == ours["count"] == 12
    assert theirs["t"] == ours["t"].tolist() and theirs["seq"] == ours["seq"].tolist()
    assert theirs["at"] == [3, 2, -1]
    for mine, node in zip(ours["robots"], theirs["robots"], strict=True):
        assert node["name"] == mine["name"] and node["index"] == mine["index"]
        assert node["jointCount"] == mine["joints"].shape[1]
        assert node["linkCount"] == mine["links"].shape[1]
        assert node["ok"] == mine["ok"].astype(int).tolist()
        np.testing.assert_array_equal(as_floats(node["joints"]), mine["joints"].ravel())
        np.testing.assert_array_equal(node["tcp"], mine["tcp"].ravel())
        np.testing.assert_array_equal(node["links"], mine["links"].ravel())
        assert node["errors"] == [list(e) for e in mine["errors"]]
    kin12, iiwa7 = ours["robots"][0], ours["robots"][1]
    assert kin12["errors"] == [[0, "unreachable posture"]] and not kin12["ok"].any()
    assert iiwa7["errors"][0][0] == 5 and math.isnan(iiwa7["joints"][5, 2])
