"""Frame rate of the page without a GPU: software WebGL in both Chromium paths, and the 2D view.

Chromium without a GPU draws WebGL with SwiftShader in one of two ways: by
default in its GPU process, which also composites and rasterises the page
(what a user on a VM or a PC without a GPU driver gets), or, with
``--disable-gpu``, with software compositing. Both are measured, each in its own
browser, at 1280x800 with the demo cell, TCP trails on and iiwa7's seven joint
plots shown:

- the page in ``auto`` after at most 10 s of adapting (the level it settled on);
- the page's 2D view, picked (``?view=2d``);
- two references in the same browser: a bare three.js cube (one draw call) and the
  page's own stage (``Stage`` from static/js/scene.js: the same renderer, floor,
  grid and lights, no robots, no DOM), at the lowest level's settings, drawing
  every animation frame;
- with ``--levels``, the page pinned at each quality level (``?quality=N``), once.

Then the 2D view in a browser without WebGL (``--disable-webgl --disable-3d-apis``),
in both paths.

The page draws a frame only when it shows something new (static/js/frame_gate.js),
so its rate is frames drawn (``window.linkview.framesDrawn``), at most the rate at
which poses arrive (frames received per robot, the median robot); the references'
rate is animation frames. Each case runs ``--repeats`` times, the cases of one
repetition one after the other; the table gives medians, and each ratio to the cube is the
median of the ratios within one repetition (the machine's load drifts between
them). Beside each rate: the CPU model, and Chromium's CPU time per frame in its
GPU process (SwiftShader's rasterising and compositing, by default) and in the
page's renderer process, read from /proc for this run's browser only. Usage:
``python bench/page_fps.py [--seconds 5] [--repeats 3] [--levels] [--quick]``;
writes docs/benchmarks.md (not with ``--quick``).
"""

from __future__ import annotations

import argparse
import functools
import os
import statistics
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from playwright.sync_api import Browser, Page, sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import cpu_model, markdown_table, publish  # noqa: E402

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
NO_WEBGL = ["--disable-webgl", "--disable-3d-apis"]

COUNT_FRAMES = """ms => new Promise(done => {
  let frames = 0; const start = performance.now();
  function tick() {
    frames++;
    if (performance.now() - start < ms) requestAnimationFrame(tick);
    else done(frames * 1000 / (performance.now() - start));
  }
  requestAnimationFrame(tick);
})"""

COUNT_DRAWN = """ms => new Promise(done => {
  const drawn = window.linkview.framesDrawn, start = performance.now();
  const poses = Object.values(window.linkview.framesReceived);
  setTimeout(() => {
    const s = (performance.now() - start) / 1000;
    const now = Object.values(window.linkview.framesReceived);
    const applied = now.map((n, i) => (n - poses[i]) / s).sort((a, b) => a - b);
    done([(window.linkview.framesDrawn - drawn) / s, applied[applied.length >> 1]]);
  }, ms);
})"""

CUBE_PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script type="importmap">
{"imports": {"three": "/static/vendor/three/build/three.module.js"}}</script></head>
<body style="margin:0; overflow:hidden">
<script type="module">
import * as THREE from 'three';
const renderer = new THREE.WebGLRenderer({ antialias: false, alpha: true });
renderer.setPixelRatio(1);
renderer.setSize(innerWidth, innerHeight);
renderer.toneMapping = THREE.NeutralToneMapping;
document.body.append(renderer.domElement);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(40, innerWidth / innerHeight, 0.1, 100);
camera.position.set(0, 0, 4);
const cube = new THREE.Mesh(new THREE.BoxGeometry(1, 1, 1),
  new THREE.MeshStandardMaterial({ color: 0x2f6fd6 }));
scene.add(cube, new THREE.HemisphereLight(0xffffff, 0x444444, 2));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(2, 2, 4);
scene.add(sun);
renderer.setAnimationLoop(() => {
  cube.rotation.x += 0.01; cube.rotation.y += 0.02; renderer.render(scene, camera);
});
window.ready = true;
</script></body></html>"""
"""The bare cube, at the lowest level's settings (no antialiasing, no shadows)."""

STAGE_PAGE = """<!DOCTYPE html><html><head><meta charset="utf-8"><script type="importmap">
{"imports": {"three": "/static/vendor/three/build/three.module.js",
 "three/addons/": "/static/vendor/three/examples/jsm/"}}</script>
<link rel="stylesheet" href="/static/css/linkview.css"></head>
<body><main id="viewport"></main>
<script type="module">
import { Stage } from '/static/js/scene.js';
const stage = new Stage(document.getElementById('viewport'),
  { shadows: false, antialias: false, pixelRatio: 1, environment: false, simpleMaterials: true });
stage.setAnimationLoop(() => {
  stage.controls.update(); stage.renderer.render(stage.scene, stage.camera);  // every frame
});
window.ready = true;
</script></body></html>"""


def _descendants() -> list[int]:
    """This process's descendants: the Chromium this run started, not another's on the machine."""
    children: dict[int, list[int]] = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            parent = int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
        except OSError:  # gone meanwhile
            continue
        children.setdefault(parent, []).append(int(pid))
    found, todo = [], [os.getpid()]
    while todo:
        pid = todo.pop()
        found.append(pid)
        todo += children.get(pid, [])
    return found


def chromium_cpu_s() -> dict[str, float]:
    """CPU seconds so far of this run's Chromium processes, summed by kind (``gpu-process``, ...).

    Read from /proc: which process burns the time tells rasterising and compositing
    (the GPU process, where SwiftShader runs by default) from the page's own work.
    """
    tick = os.sysconf("SC_CLK_TCK")
    spent: dict[str, float] = {}
    for pid in _descendants():
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
    """Frames per second, poses received per robot per second, Chromium's CPU ms per frame."""

    fps: float
    cpu_ms: dict[str, float]
    poses: float | None = None


def measured(page: Page, seconds: float, drawn: bool) -> Rate:
    """Frames drawn by the page (``drawn``) or animation frames per second, over ``seconds``."""
    before = chromium_cpu_s()
    poses = None
    if drawn:
        fps, poses = page.evaluate(COUNT_DRAWN, seconds * 1000)
    else:
        fps = page.evaluate(COUNT_FRAMES, seconds * 1000)
    after = chromium_cpu_s()
    frames = max(fps * seconds, 1.0)
    cpu_ms = {kind: 1000 * (after[kind] - before.get(kind, 0.0)) / frames for kind in after}
    return Rate(fps, cpu_ms, poses)


def reference(page: Page, url: str, html: str, seconds: float, warm_up_ms: int) -> Rate:
    """The frame rate of a reference page (served at the page's origin, outside its CSP)."""
    page.route(
        "**/bench/reference", lambda route: route.fulfill(body=html, content_type="text/html")
    )
    try:
        page.goto(f"{url}/bench/reference")
        page.wait_for_function("() => window.ready === true")
        page.wait_for_timeout(warm_up_ms)
        return measured(page, seconds, drawn=False)
    finally:
        page.unroute("**/bench/reference")


def page_rate(page: Page, url: str, query: str, seconds: float, wait_ms: int) -> Rate:
    """The page's frames drawn per second with ``query``, after ``wait_ms``."""
    open_page(page, f"{url}/?{query}")
    page.select_option("#selected-robot", "iiwa7")  # seven joint plots
    page.wait_for_timeout(wait_ms)
    assert page.evaluate("window.linkview.robotState('iiwa7').trailPoints") > 0, "trail is off"
    return measured(page, seconds, drawn=True)


def webgl_renderer(page: Page) -> str:
    """What the browser says draws its WebGL (SwiftShader, and through what)."""
    name: str = page.evaluate(
        """() => { const gl = document.createElement('canvas').getContext('webgl2');
          const info = gl && gl.getExtension('WEBGL_debug_renderer_info');
          if (!gl) return 'none';
          return gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER); }"""
    )
    return name


@dataclass
class Case:
    """One row: a way to measure, and its rates over the repetitions."""

    label: str
    run: Callable[[Page], Rate]
    rates: list[Rate]


def row(case: Case, cube: Case | None) -> list[str]:
    """The case's medians, and its ratio to the cube's rate (median of per-repetition ratios)."""
    median = statistics.median
    fps = [r.fps for r in case.rates]
    gpu = median(r.cpu_ms.get("gpu-process", 0.0) for r in case.rates)
    page = median(r.cpu_ms.get("renderer", 0.0) for r in case.rates)
    ratio = ""
    if cube is not None and case is not cube:
        ratio = f"{median(a.fps / b.fps for a, b in zip(case.rates, cube.rates, strict=True)):.2f}"
    poses = [r.poses for r in case.rates if r.poses is not None]
    return [
        case.label,
        cpu_model(),
        f"**{median(fps):.1f}**",
        " / ".join(f"{f:.1f}" for f in fps),
        ratio,
        f"{gpu:.0f} / {page:.0f}",
        f"{median(poses):.1f}" if poses else "",
    ]


def measure(browser: Browser, cases: list[Case], repeats: int) -> None:
    """Run every case ``repeats`` times, the cases of one repetition in a row, each in a new tab."""
    for repeat in range(repeats):
        for case in cases:
            page = browser.new_page(viewport=VIEWPORT)
            try:
                case.rates.append(case.run(page))
            finally:
                page.close()
            rate = case.rates[-1]
            print(f"{repeat + 1}/{repeats} {case.label}: {rate.fps:.1f} frames/s", flush=True)


HEADER = [
    "what",
    "CPU",
    "frames/s (median)",
    "each run",
    "ratio to the bare cube",
    "CPU ms per frame: GPU process / page",
    "poses received/s per robot",
]


def webgl_section(browser: Browser, url: str, args: argparse.Namespace) -> tuple[str, str]:
    """Rows for one browser with software WebGL, and its WebGL renderer's name."""
    seconds, warm = args.seconds, args.warm_up_ms

    def auto(page: Page) -> Rate:
        rate = page_rate(page, url, "quality=auto", seconds, args.settle_ms)
        level = page.evaluate("window.linkview.quality.level")
        settled.append(level)
        return rate

    settled: list[int] = []

    def with_query(query: str) -> Callable[[Page], Rate]:
        return functools.partial(page_rate, url=url, query=query, seconds=seconds, wait_ms=warm)

    cube = Case("reference: bare cube", lambda p: reference(p, url, CUBE_PAGE, seconds, warm), [])
    cases = [
        Case("**page, auto**", auto, []),
        cube,
        Case("page, 2D view (`?view=2d`)", with_query("view=2d"), []),
        Case(
            "reference: the page's stage, no robots, no DOM",
            lambda p: reference(p, url, STAGE_PAGE, seconds, warm),
            [],
        ),
    ]
    measure(browser, cases, args.repeats)
    cases[0].label += f" (level {' / '.join(map(str, settled))} after {args.settle_ms / 1000:g} s)"
    rows = [row(case, cube) for case in cases]
    if args.levels:
        for index, name in enumerate(LEVELS):
            level = Case(f"page, level {index} ({name})", with_query(f"quality={index}"), [])
            measure(browser, [level], 1)
            rows.append(row(level, None))
    page = browser.new_page(viewport=VIEWPORT)
    renderer = webgl_renderer(page)  # on about:blank
    page.close()
    return markdown_table(HEADER, rows), renderer


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.2f} (1 min), {five:.2f} (5 min)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="counting time per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each case")
    parser.add_argument("--levels", action="store_true", help="also each level pinned, once")
    parser.add_argument("--quick", action="store_true", help="one path, one run, 1 s; no docs")
    args = parser.parse_args()
    args.warm_up_ms, args.settle_ms = WARM_UP_MS, AUTO_SETTLE_MS
    paths = PATHS
    if args.quick:
        args.seconds, args.repeats, args.levels = 1.0, 1, False
        args.warm_up_ms, args.settle_ms = 1000, 2000
        paths = {"--disable-gpu": CHROMIUM_ARGS}
    load_before = load()
    sections: list[str] = []
    with (
        tempfile.TemporaryDirectory() as tmp,
        server_process(free_port(), Path(tmp) / "server.log") as url,
        sync_playwright() as pw,
    ):
        for path, flags in paths.items():
            print(f"-- {path}", flush=True)
            browser = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=flags)
            table, renderer = webgl_section(browser, url, args)
            browser.close()
            sections.append(f"### {path}\n\nWebGL renderer: `{renderer}`.\n\n{table}")
        rows = []
        for path, flags in paths.items():
            print(f"-- {path}, no WebGL", flush=True)
            browser = pw.chromium.launch(
                executable_path=str(CHROMIUM), headless=True, args=[*flags, *NO_WEBGL]
            )
            flat = Case(
                f"2D view, no WebGL, {path}",
                lambda p: page_rate(p, url, "", args.seconds, args.warm_up_ms),
                [],
            )
            measure(browser, [flat], args.repeats)
            browser.close()
            rows.append(row(flat, None))
        sections.append(f"### No WebGL (`{' '.join(NO_WEBGL)}`)\n\n{markdown_table(HEADER, rows)}")
    load_after = load()
    body = (
        f"Headless Chromium (`{CHROMIUM}`, `--use-angle=swiftshader "
        "--enable-unsafe-swiftshader`), without (the default: SwiftShader in the GPU process, "
        "which also composites and rasterises the page) and with `--disable-gpu` (software "
        f"compositing), at {VIEWPORT['width']}x{VIEWPORT['height']}, device pixel ratio 1, the "
        "demo cell with TCP trails on, iiwa7's seven joint plots shown. The page's rate is "
        "frames drawn (a frame with nothing new is not drawn: at most the rate poses arrive); "
        "the references' is animation frames. "
        f"{args.seconds:g} s counted after a {args.warm_up_ms / 1000:g} s warm-up (in `auto`: "
        f"after {args.settle_ms / 1000:g} s of adapting), {args.repeats} runs of each case, "
        "the cases of one run one after the other; ratios are the median of each run's ratio. "
        "The machine is shared with other work: load average before: "
        f"{load_before}; after: {load_after}.\n\n" + "\n\n".join(sections) + "\n"
    )
    if args.quick:
        print(body)
        return
    publish("bench/page_fps.py", "Page frame rate with software rendering", body)


if __name__ == "__main__":
    main()
