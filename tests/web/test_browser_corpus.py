"""Published robot descriptions on the page: each one is drawn, and a missing mesh is told.

A cell holds several robots of the corpus (``tests/urdf/corpus.py``: a KUKA
KR 6 from xacro with COLLADA meshes, a PUMA 560 from xacro, pybullet's KUKA
LBR iiwa, an Interbotix PincherX 100 with mimic fingers and xacro arguments,
and the MIT RACECAR) and one written here whose mesh is missing.
The lighter robots of the corpus are picked: software rendering on two shared
cores pays for every triangle. The test looks at the screenshot's pixels: hiding a robot must
change many of them, and those around where it stands (its links projected with the page's
camera), so each robot is really drawn, and in its place, not only in the DOM.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
from PIL import Image
from playwright.sync_api import Browser, Page

from server.cell import load_cell
from server.urdf import load_urdf
from tests.conftest import free_port
from tests.urdf.corpus import CORPUS
from tests.web._browser import on_screen, open_page, screenshot, server_process, watch

TIMEOUT_MS = 180_000  # software rendering on shared cores: loading is slow
SHOWN = ("kuka_kr6", "puma560", "kuka_iiwa", "px100", "racecar")
SPACING_MM = 1100.0
MIN_PIXELS = 400  # a robot at this distance covers thousands; a stray edge a few dozen
REACH_PX = 60.0
"""How far a robot's meshes reach beyond its link origins on screen, at most (here)."""
WHERE_SHARE = 0.9
"""Of the pixels a robot changes, the share around its own links (its shadow may fall out)."""

BROKEN = """<robot name="broken">
  <link name="base"><visual><geometry><mesh filename="meshes/base.stl"/></geometry></visual></link>
  <link name="arm"/>
  <joint name="lift" type="prismatic">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.2"/>
  </joint>
</robot>
"""


STANDS: dict[str, np.ndarray] = {}
"""Per robot, its link origins in the world (m) at rest: from the URDF (linkview's loader,
checked against pinocchio by tests/urdf/test_corpus.py) and the base the cell gives it."""


def robot_entry(name: str, file: Path, x_mm: float, extra: str = "") -> str:
    """A ``[[robot]]`` table at ``x_mm`` along X, resting at zero (clipped to its limits)."""
    kwargs = {}
    described = next((r for r in CORPUS if r.name == name), None)
    if described is not None:
        kwargs = {"packages": described.package_folders, "args": described.args}
    chain = load_urdf(file, **kwargs).chain  # type: ignore[arg-type]
    units = chain.joint_units
    joints = ", ".join(
        f'{{ node = "motion/axs/{name}_{k}/state/values/actual/pos", unit = "{u}" }}'
        for k, u in enumerate(units)
    )
    rest = np.clip(0.0, np.nan_to_num(chain.limits[:, 0]), np.nan_to_num(chain.limits[:, 1]))
    poses, _ = chain.link_poses(rest)
    STANDS[name] = poses[:, :3, 3] + [x_mm / 1000.0, 0.0, 0.0]
    return (
        f'[[robot]]\nname = "{name}"\nsource = "mock"\nbase = {{ xyz = [{x_mm}, 0, 0] }}\n'
        f'kinematics = {{ type = "urdf", file = "{file}" {extra} }}\n'
        f"joints = [{joints}]\ndemo_targets = [{rest.tolist()}]\n"
    )


def write_cell(folder: Path) -> Path:
    parts = ['[[source]]\nname = "mock"\n']
    for i, name in enumerate(SHOWN):
        robot = next(r for r in CORPUS if r.name == name)
        packages = ", ".join(f'{k} = "{v}"' for k, v in robot.package_folders.items())
        args = ", ".join(f'{k} = "{v}"' for k, v in robot.args.items())
        extra = f", packages = {{ {packages} }}, args = {{ {args} }}"
        parts.append(robot_entry(name, robot.path, i * SPACING_MM, extra))
    (folder / "broken.urdf").write_text(BROKEN)
    parts.append(robot_entry("broken", folder / "broken.urdf", len(SHOWN) * SPACING_MM))
    cell = folder / "corpus.toml"
    cell.write_text("\n".join(parts))
    return cell


def pixels(page: Page) -> np.ndarray:
    """The page as an (h, w, 3) int array of what is on screen now."""
    page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
    image = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
    return np.asarray(image, dtype=np.int16)


def stands(page: Page, name: str) -> tuple[float, float, float, float]:
    """The screen rectangle (left, top, right, bottom; px) of the robot's link origins at rest
    (``STANDS``), projected with the page's camera, widened by ``REACH_PX`` for the meshes
    around them."""
    points = on_screen(page, list(STANDS[name]))
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return min(xs) - REACH_PX, min(ys) - REACH_PX, max(xs) + REACH_PX, max(ys) + REACH_PX


def inside(diff: np.ndarray, box: tuple[float, float, float, float]) -> float:
    """The share of the changed pixels within ``box``."""
    rows, cols = np.nonzero(diff)
    left, top, right, bottom = box
    within = (cols >= left) & (cols <= right) & (rows >= top) & (rows <= bottom)
    return float(within.mean()) if len(rows) else 0.0


def settled(page: Page, names: list[str]) -> None:
    """Wait until no robot moves (each rests at its one demo target)."""
    script = "names => JSON.stringify(names.map(n => window.linkview.linkMatrices(n)))"
    before = page.evaluate(script, names)
    for _ in range(100):
        page.wait_for_timeout(300)
        now = page.evaluate(script, names)
        if now == before:
            return
        before = now
    raise AssertionError("the robots did not come to rest")


def test_published_robots_are_drawn_and_a_missing_mesh_is_told(
    browser: Browser, tmp_path: Path
) -> None:
    cell = write_cell(tmp_path)
    cache = tmp_path / "cache"
    loaded = load_cell(cell, env={}, cache_dir=cache)  # converts the meshes before the clock runs
    warnings = {robot.name: robot.warnings for robot in loaded.robots}
    assert all(not warnings[name] for name in SHOWN), warnings
    (missing,) = warnings["broken"]
    assert "base.stl not found" in missing

    env = {"LINKVIEW_CACHE_DIR": str(cache)}
    with server_process(free_port(), tmp_path / "server.log", "--cell", str(cell), env=env) as url:
        page = browser.new_page(viewport={"width": 1280, "height": 720})
        watched = watch(page)
        open_page(page, f"{url}/?quality=4", TIMEOUT_MS)
        names = [*SHOWN, "broken"]
        settled(page, names)
        screenshot(page, "corpus.png")
        everything = pixels(page)

        canvas = page.evaluate(
            "(() => { const r = document.querySelector('#viewport canvas').getBoundingClientRect();"
            " return [r.left, r.top, r.width, r.height]; })()"
        )
        view = np.zeros(everything.shape[:2], dtype=bool)
        left, top, width, height = (round(v) for v in canvas)
        view[top : top + height, left : left + width] = True
        changed, where = {}, {}
        for name in names:
            show = page.get_by_label(f"show {name}")
            show.uncheck()
            without = pixels(page)
            show.check()
            diff = np.abs(everything - without).sum(axis=2) > 30
            diff &= view  # the robot's card and panels change too: the 3D view only
            changed[name] = int(diff.sum())
            where[name] = inside(diff, stands(page, name))
            if name == "kuka_kr6":
                # KUKA orange is in what it draws (its meshes' own colours, or the URDF's).
                r, g, b = (everything[diff][:, c] for c in range(3))
                assert int(((r > 150) & (r > g + 40) & (g > b)).sum()) > MIN_PIXELS
        assert all(count > MIN_PIXELS for count in changed.values()), changed
        # Where it stands: the pixels it changed are around its own links on screen.
        assert all(share >= WHERE_SHARE for share in where.values()), where
        # Links without a visual draw nothing: no ball-and-stick beside the meshes.
        stand_ins = page.evaluate(
            "names => names.map(n => window.linkview.robotState(n).standIns)", names
        )
        assert stand_ins == [0] * len(names)

        card = page.locator("article.robot[data-robot='broken'] details.robot-warnings")
        assert card.locator("summary").inner_text() == "1 warning"
        assert not card.locator("li").is_visible()  # folded until asked for
        card.locator("summary").click()
        # As the page shows it: the files named relative to the cell's folder.
        shown = card.locator("li").inner_text()
        assert shown == loaded.shown(missing) and str(tmp_path) not in shown, shown
        assert shown.startswith("broken.urdf, line 2: link 'base': mesh file meshes/base.stl")
        card.scroll_into_view_if_needed()
        screenshot(page, "corpus-warning.png")
        assert page.locator("details.robot-warnings").count() == 1
        assert math.isfinite(page.evaluate("window.linkview.renderInfo.triangles"))
        watched.assert_clean()
        page.close()
