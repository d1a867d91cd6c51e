"""A cell written by ``discover`` brought to a correct, saved cell from the page alone.

The mock runs on its own, as a controller would; ``discover`` writes the
starter cell (robots 1 m apart, the positioner's axes as placeholders 200 mm
apart, no descriptions). On the page (``_bring_up.bring_up``): the iiwa gets a
URDF from the cell's folder; the Type 12 is placed by numbers; the
positioner's tilt axis, then its turntable, are calibrated from three TCP
samples each (a mark on the table, touched by the iiwa's TCP at three axis
positions) and applied; the diff is reviewed and saved. The saved file then
describes the machine ``_bring_up`` writes out: the turntable's frame is where
the machine has it, at any tilt and turn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from playwright.sync_api import Browser
from scipy.spatial.transform import Rotation

from server.cell import load_cell
from tests.conftest import free_port
from tests.web._bring_up import ENV, bring_up, discover, true_table
from tests.web._browser import mock_process, open_page, server_process, watch

TIMEOUT_MS = 180_000


def test_a_discovered_cell_is_brought_up_and_saved_from_the_page(
    browser: Browser, tmp_path: Path
) -> None:
    folder = tmp_path / "cell"
    folder.mkdir()
    cell = folder / "cell.toml"
    env = {**ENV, "LINKVIEW_CACHE_DIR": str(tmp_path / "cache")}
    with mock_process(free_port(), tmp_path / "mock.log", "--hold-s", "3600") as mock_url:
        discovered = discover(mock_url, cell)
        args = ("--cell", str(cell), "--allow-edits", "--allow-commands")
        with server_process(free_port(), tmp_path / "server.log", *args, env=env) as url:
            page = browser.new_page(viewport={"width": 1400, "height": 900})
            page.set_default_timeout(TIMEOUT_MS)
            watched = watch(page)
            open_page(page, f"{url}/?quality=5", TIMEOUT_MS)
            fits = bring_up(page, url, lambda name: None)
            watched.assert_clean()
    # The mark is 100 mm from either axis; the samples lie exactly on their circles.
    for text in fits.values():
        assert "radius 100.000 mm · max error 0.000 mm · mean error 0.000 mm" in text
    assert (folder / "cell.toml.bak").read_text() == discovered
    saved = load_cell(cell, env=ENV, cache_dir=tmp_path / "cache")
    robots = {r.name: r for r in saved.robots}
    assert robots["iiwa"].family == "urdf" and robots["iiwa"].base[:3] == (0.0, 0.0, 0.0)
    np.testing.assert_allclose(robots["kin12"].base, [-0.75, 0.35, 0, 0, 0, 0, 1], atol=1e-12)
    # The turntable is where the machine has it, at tilts and turns never sampled.
    positioner = robots["pos"]
    base = np.eye(4)
    base[:3, :3] = Rotation.from_quat(positioner.base[3:]).as_matrix()
    base[:3, 3] = positioner.base[:3]
    for tilt_deg, turn_deg in ((0, 0), (-45, 30), (20, -300), (55, 123)):
        q = np.radians([tilt_deg, turn_deg])
        links, _, ok = positioner.poses(q)
        assert ok
        np.testing.assert_allclose(base @ links[2], true_table(*q), atol=1e-6)
    # Every comment of the discovered file is still there.
    kept = cell.read_text()
    assert all(ln.strip() in kept for ln in discovered.splitlines() if ln.lstrip().startswith("#"))
