"""Frame rate of the page with software rendering, per quality level, beside a bare three.js cube.

Starts ``python -m server`` (the demo cell, embedded mock), opens the page in
Debian's Chromium with the browser tests' flags (SwiftShader WebGL, no GPU) at
1280x800, pins each quality level with ``?quality=N`` (TCP trail on, as by
default) and counts ``requestAnimationFrame`` callbacks over a few seconds after
a warm-up. The reference is a bare scene in the same browser: one rotating
cube with the level's renderer settings (antialiasing, pixel ratio, tone
mapping, shadow map), served at the same origin. Then the page in ``auto``
mode: which level it settles on, and its frame rate there.

Frame rates depend on what else the machine does: the load average before and
after is printed with the table. Usage: ``python bench/page_fps.py [--seconds 5]``;
writes docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from playwright.sync_api import Page, sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402

from tests.web._browser import (  # noqa: E402
    CHROMIUM,
    CHROMIUM_ARGS,
    free_port,
    open_page,
    server_process,
)

VIEWPORT = {"width": 1280, "height": 800}
# static/js/quality.js LEVELS, in order: (name, antialias, shadows).
LEVELS = [
    ("full", True, True),
    ("no shadows", True, False),
    ("no antialiasing", False, False),
    ("pixel ratio 1", False, False),
    ("no environment", False, False),
    ("simple meshes", False, False),
]
WARM_UP_MS = 3000
AUTO_SETTLE_MS = 25_000

COUNT_FRAMES = """ms => new Promise(done => {
  let frames = 0; const start = performance.now();
  function tick() {
    frames++;
    if (performance.now() - start < ms) requestAnimationFrame(tick);
    else done(frames * 1000 / (performance.now() - start));
  }
  requestAnimationFrame(tick);
})"""

CUBE_PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script type="importmap">
{"imports": {"three": "/static/vendor/three/build/three.module.js"}}</script></head>
<body style="margin:0; overflow:hidden">
<script type="module">
import * as THREE from 'three';
const renderer = new THREE.WebGLRenderer({ antialias: %(antialias)s, alpha: true });
renderer.setPixelRatio(1);
renderer.setSize(innerWidth, innerHeight);
renderer.toneMapping = THREE.NeutralToneMapping;
renderer.shadowMap.enabled = %(shadows)s;
document.body.append(renderer.domElement);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(40, innerWidth / innerHeight, 0.1, 100);
camera.position.set(0, 0, 4);
const cube = new THREE.Mesh(new THREE.BoxGeometry(1, 1, 1),
  new THREE.MeshStandardMaterial({ color: 0x2f6fd6 }));
cube.castShadow = true;
scene.add(cube, new THREE.HemisphereLight(0xffffff, 0x444444, 2));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, 2, 4);
sun.castShadow = true;
scene.add(sun);
renderer.setAnimationLoop(() => {
  cube.rotation.x += 0.01; cube.rotation.y += 0.02; renderer.render(scene, camera);
});
window.ready = true;
</script></body></html>"""


def frames_per_second(page: Page, seconds: float) -> float:
    """requestAnimationFrame callbacks per second over ``seconds`` (after the caller's warm-up)."""
    fps: float = page.evaluate(COUNT_FRAMES, seconds * 1000)
    return fps


def cube_fps(page: Page, url: str, antialias: bool, shadows: bool, seconds: float) -> float:
    """The bare cube's frame rate with these renderer settings."""
    html = CUBE_PAGE % {"antialias": str(antialias).lower(), "shadows": str(shadows).lower()}
    page.route("**/bench/cube", lambda route: route.fulfill(body=html, content_type="text/html"))
    try:
        page.goto(f"{url}/bench/cube")
        page.wait_for_function("() => window.ready === true")
        page.wait_for_timeout(WARM_UP_MS)
        return frames_per_second(page, seconds)
    finally:
        page.unroute("**/bench/cube")


def page_fps(
    page: Page, url: str, quality: str, seconds: float
) -> tuple[float, float, dict[str, int]]:
    """The page's frame rate at a pinned level, its plots' redraws/s, what it drew per frame."""
    open_page(page, f"{url}/?quality={quality}")
    page.select_option("#selected-robot", "iiwa7")  # seven joint plots
    page.wait_for_timeout(WARM_UP_MS)
    assert page.evaluate("window.linkview.robotState('iiwa7').trailPoints") > 0, "trail is off"
    redraws = page.evaluate("window.linkview.plots.redraws")
    fps = frames_per_second(page, seconds)
    plots = (page.evaluate("window.linkview.plots.redraws") - redraws) / seconds
    info: dict[str, int] = page.evaluate("window.linkview.renderInfo")
    return fps, plots, info


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.2f} (1 min), {five:.2f} (5 min)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="counting time per run")
    args = parser.parse_args()
    load_before = load()
    rows: list[list[str]] = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        server_process(free_port(), Path(tmp) / "server.log") as url,
        sync_playwright() as pw,
    ):
        browser = pw.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        page = browser.new_page(viewport=VIEWPORT)
        for index, (name, antialias, shadows) in enumerate(LEVELS):
            fps, plots, info = page_fps(page, url, str(index), args.seconds)
            cube = cube_fps(page, url, antialias, shadows, args.seconds)
            rows.append(
                [
                    f"{index} {name}",
                    f"{fps:.1f}",
                    f"{cube:.1f}",
                    f"{fps / cube:.2f}",
                    f"{plots:.1f}",
                    f"{info['calls']} / {info['triangles']}",
                ]
            )
            print(" | ".join(rows[-1]), flush=True)
        open_page(page, f"{url}/?quality=auto")
        page.wait_for_timeout(AUTO_SETTLE_MS)
        settled = page.evaluate("window.linkview.quality")
        auto_fps = frames_per_second(page, args.seconds)
        browser.close()
    load_after = load()
    table = markdown_table(
        [
            "quality level",
            "page frames/s",
            "bare cube frames/s",
            "page / cube",
            "plot redraws/s",
            "draws / triangles",
        ],
        rows,
    )
    auto = (
        f"In `auto` the page settled after {AUTO_SETTLE_MS / 1000:.0f} s on level "
        f"{settled['level']} after {settled['changes']} change(s), at {auto_fps:.1f} frames/s."
    )
    body = (
        f"Headless Chromium (`{CHROMIUM}`, SwiftShader, no GPU) at "
        f"{VIEWPORT['width']}x{VIEWPORT['height']}, device pixel ratio 1, the demo cell with "
        f"TCP trails on, iiwa7's seven joint plots shown; {args.seconds:g} s of "
        f"requestAnimationFrame counted after a "
        f"{WARM_UP_MS / 1000:g} s warm-up. Load average before: {load_before}; after: "
        f"{load_after}.\n\n{table}\n\n{auto}\n"
    )
    publish("bench/page_fps.py", "Page frame rate with software rendering", body)


if __name__ == "__main__":
    main()
