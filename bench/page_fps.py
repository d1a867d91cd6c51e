"""Frame rate of the page with software WebGL, in both of Chromium's paths, beside two references.

Chromium without a GPU draws WebGL with SwiftShader in one of two ways: by
default in its GPU process, which also composites and rasterises the page
(what a user on a VM or a PC without a GPU driver gets), or, with
``--disable-gpu``, with software compositing. Both are measured, each in its own
browser, at 1280x800 with the demo cell and TCP trails on:

- the page pinned at each quality level (``?quality=N``), and in ``auto`` after
  at most 10 s of adapting (the level it settled on);
- a bare three.js cube (one draw call) and the page's own stage (``Stage`` from
  static/js/scene.js: the same renderer, floor, grid and lights, no robots, no
  DOM), at the lowest level's settings, in the same browser.

Frames are ``requestAnimationFrame`` callbacks counted after a warm-up; every
callback of the page renders. Beside each rate: Chromium's CPU time per frame
in its GPU process (SwiftShader's rasterising and compositing, by default) and
in the page's renderer process, read from /proc, which says where the time
goes. Frame rates depend on what else the machine does: the load average is
printed with the table. Usage: ``python bench/page_fps.py
[--seconds 5]``; writes docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from playwright.sync_api import Page, sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402

from tests.conftest import free_port  # noqa: E402
from tests.web._browser import CHROMIUM, CHROMIUM_ARGS, open_page, server_process  # noqa: E402

VIEWPORT = {"width": 1280, "height": 800}
LEVELS = [
    "full",
    "no shadows",
    "no antialiasing",
    "pixel ratio 1",
    "no environment",
    "simple meshes",
]
"""static/js/quality.js LEVELS' names, in order."""
WARM_UP_MS = 3000
AUTO_SETTLE_MS = 10_000
"""The issue's bound on adapting: measured after at most this long in 'auto'."""
PATHS = {
    "GPU process (default)": [a for a in CHROMIUM_ARGS if a != "--disable-gpu"],
    "--disable-gpu": CHROMIUM_ARGS,
}

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


STAGE_PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script type="importmap">
{"imports": {"three": "/static/vendor/three/build/three.module.js",
 "three/addons/": "/static/vendor/three/examples/jsm/"}}</script>
<link rel="stylesheet" href="/static/css/linkview.css"></head>
<body><main id="viewport"></main>
<script type="module">
import { Stage } from '/static/js/scene.js';
const stage = new Stage(document.getElementById('viewport'),
  { shadows: false, antialias: false, pixelRatio: 1, environment: false, simpleMaterials: true });
stage.setAnimationLoop(() => stage.render());
window.ready = true;
</script></body></html>"""


def chromium_cpu_s() -> dict[str, float]:
    """CPU seconds so far of Chromium's processes, summed by kind (``gpu-process``, ``renderer``).

    Read from /proc: which process burns the time tells rasterising and compositing
    (the GPU process, where SwiftShader runs by default) from the page's own work.
    """
    tick = os.sysconf("SC_CLK_TCK")
    spent: dict[str, float] = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            argv = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").split()
            if not argv or b"chrom" not in argv[0]:
                continue
            kind = next((a[7:].decode() for a in argv if a.startswith(b"--type=")), "browser")
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:  # gone meanwhile
            continue
        spent[kind] = spent.get(kind, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return spent


@dataclass
class Rate:
    """Frames per second, and Chromium's CPU milliseconds per frame by process kind."""

    fps: float
    cpu_ms: dict[str, float]

    def cells(self) -> list[str]:
        gpu, page = self.cpu_ms.get("gpu-process", 0.0), self.cpu_ms.get("renderer", 0.0)
        return [f"{self.fps:.1f}", f"{gpu:.0f} / {page:.0f}"]


def frames_per_second(page: Page, seconds: float) -> Rate:
    """requestAnimationFrame callbacks per second over ``seconds`` (after the caller's warm-up)."""
    before = chromium_cpu_s()
    fps: float = page.evaluate(COUNT_FRAMES, seconds * 1000)
    after = chromium_cpu_s()
    frames = max(fps * seconds, 1.0)
    cpu_ms = {kind: 1000 * (after[kind] - before.get(kind, 0.0)) / frames for kind in after}
    return Rate(fps, cpu_ms)


def reference_fps(page: Page, url: str, html: str, seconds: float) -> Rate:
    """The frame rate of a reference page (served at the page's origin, outside its CSP)."""
    page.route(
        "**/bench/reference", lambda route: route.fulfill(body=html, content_type="text/html")
    )
    try:
        page.goto(f"{url}/bench/reference")
        page.wait_for_function("() => window.ready === true")
        page.wait_for_timeout(WARM_UP_MS)
        return frames_per_second(page, seconds)
    finally:
        page.unroute("**/bench/reference")


def webgl_renderer(page: Page) -> str:
    """What the browser says draws its WebGL (SwiftShader, and through what)."""
    name: str = page.evaluate(
        """() => { const gl = document.createElement('canvas').getContext('webgl2');
          const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
          if (!gl) return 'none';
          return gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER); }"""
    )
    return name


def page_fps(
    page: Page, url: str, quality: str, seconds: float
) -> tuple[Rate, float, dict[str, int]]:
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


def measure_path(page: Page, url: str, seconds: float) -> tuple[list[list[str]], str]:
    """Rows for one browser: each level pinned, auto after adapting, the two references."""
    rows: list[list[str]] = []
    for index, name in enumerate(LEVELS):
        rate, plots, info = page_fps(page, url, str(index), seconds)
        rows.append(
            [
                f"page, level {index} ({name})",
                *rate.cells(),
                f"{plots:.1f}",
                f"{info['calls']} / {info['triangles']}",
            ]
        )
        print(" | ".join(rows[-1]), flush=True)
    open_page(page, f"{url}/?quality=auto")
    page.select_option("#selected-robot", "iiwa7")
    page.wait_for_timeout(AUTO_SETTLE_MS)
    settled = page.evaluate("window.linkview.quality")
    redraws = page.evaluate("window.linkview.plots.redraws")
    rate = frames_per_second(page, seconds)
    plots = (page.evaluate("window.linkview.plots.redraws") - redraws) / seconds
    info = page.evaluate("window.linkview.renderInfo")
    ended = page.evaluate("window.linkview.quality")["level"]
    # 'auto' may step up (or down) while it is counted: say so, the draws are the last level's.
    moved = "" if ended == settled["level"] else f", level {ended} by the end"
    fps, cpu = rate.cells()
    rows.append(
        [
            f"**page, auto** (level {settled['level']} after {AUTO_SETTLE_MS / 1000:g} s{moved})",
            f"**{fps}**",
            cpu,
            f"{plots:.1f}",
            f"{info['calls']} / {info['triangles']}",
        ]
    )
    print(" | ".join(rows[-1]), flush=True)
    lowest = CUBE_PAGE % {"antialias": "false", "shadows": "false"}
    for label, html in (
        ("reference: the page's stage, no robots, no DOM", STAGE_PAGE),
        ("reference: bare cube", lowest),
    ):
        rows.append([label, *reference_fps(page, url, html, seconds).cells(), "", ""])
        print(" | ".join(rows[-1]), flush=True)
    return rows, webgl_renderer(page)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="counting time per run")
    args = parser.parse_args()
    load_before = load()
    sections: list[str] = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        server_process(free_port(), Path(tmp) / "server.log") as url,
        sync_playwright() as pw,
    ):
        for path, flags in PATHS.items():
            print(f"-- {path}", flush=True)
            browser = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=flags)
            page = browser.new_page(viewport=VIEWPORT)
            rows, renderer = measure_path(page, url, args.seconds)
            browser.close()
            table = markdown_table(
                [
                    "what",
                    "frames/s",
                    "CPU ms per frame: GPU process / page",
                    "plot redraws/s",
                    "draws / triangles",
                ],
                rows,
            )
            sections.append(f"### {path}\n\nWebGL renderer: `{renderer}`.\n\n{table}")
    load_after = load()
    body = (
        f"Headless Chromium (`{CHROMIUM}`, `--use-angle=swiftshader "
        "--enable-unsafe-swiftshader`), without (the default: SwiftShader in the GPU process, "
        "which also composites and rasterises the page) and with `--disable-gpu` (software "
        f"compositing), at {VIEWPORT['width']}x{VIEWPORT['height']}, device pixel ratio 1, the "
        "demo cell with TCP trails on, iiwa7's seven joint plots shown; "
        f"{args.seconds:g} s of requestAnimationFrame counted after a {WARM_UP_MS / 1000:g} s "
        f"warm-up (in `auto`: after {AUTO_SETTLE_MS / 1000:g} s of adapting). The references run "
        "in the same browser at the lowest level's settings. Load average before: "
        f"{load_before}; after: {load_after}.\n\n" + "\n\n".join(sections) + "\n"
    )
    publish("bench/page_fps.py", "Page frame rate with software rendering", body)


if __name__ == "__main__":
    main()
