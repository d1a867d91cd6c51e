"""Where a frame's time goes in Chromium's GPU process with software WebGL: a trace, per frame.

bench/page_fps.py gives frame rates and CPU per frame by process; this
records Chromium's own trace (``browser.start_tracing``) while the page runs
and sums, per presented frame, the GPU process's main-thread slices that
matter without a GPU:

- ``SwapBuffers``: presenting the frame (``SkiaOutputSurfaceImplOnGpu``);
- ``finish``: within it, waiting until SwiftShader has executed everything
  queued (WebGL draws, compositing, rasterised tiles): the GPU process does
  no other work meanwhile;
- ``copy back``: within it too, reading the frame back to memory
  (``readPixels``, less the wait);
- ``tile raster``: the page's DOM tiles rasterised (``RendererRasterWorker``);
- ``commands``: WebGL and raster command buffers decoded (``CommandBuffer::Flush``);
- ``page main``: the page's own main-thread frame (``ProxyMain::BeginMainFrame``:
  script, style, layout, paint) in the renderer process.

Cases: the page's stage (no robots, no DOM) and the page at its lowest level,
in Chromium's default path (with ``--disable-gpu`` the compositor is not in
the GPU process and these slices do not exist). Usage: ``python bench/page_trace.py [--seconds 3]``;
writes docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from playwright.sync_api import Page, sync_playwright

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from _report import markdown_table, publish  # noqa: E402
from page_fps import LEVELS, PATHS, STAGE_PAGE, VIEWPORT, WARM_UP_MS  # noqa: E402

from tests.conftest import free_port  # noqa: E402
from tests.web._browser import CHROMIUM, open_page, server_process  # noqa: E402

CATEGORIES = ["viz", "gpu", "cc", "toplevel", "benchmark", "gpu.angle"]
SLICES = {
    "SwapBuffers": "SkiaOutputSurfaceImplOnGpu::SwapBuffers",
    "finish": "ContextVk::finishImpl",
    "copy back": "ImageHelper::readPixelsImpl - CPU Readback",
    "tile raster": "RendererRasterWorker",
    "commands": "CommandBuffer::Flush",
    "page main": "ProxyMain::BeginMainFrame",
}


def traced(page: Page, seconds: float) -> dict[str, Any]:
    """The trace of ``seconds`` of the page as it runs."""
    browser = page.context.browser
    assert browser is not None
    browser.start_tracing(page=page, categories=CATEGORIES)
    page.wait_for_timeout(seconds * 1000)
    data: dict[str, Any] = json.loads(browser.stop_tracing())
    return data


def per_frame(trace: dict[str, Any], seconds: float) -> list[str]:
    """Presented frames/s and each slice's ms per presented frame."""
    events = trace["traceEvents"]
    kinds = {
        e["pid"]: e["args"]["name"]
        for e in events
        if e.get("ph") == "M" and e.get("name") == "process_name"
    }
    wanted = {name: key for key, name in SLICES.items()}
    total: Counter[str] = Counter()
    swaps = 0
    for e in events:
        key = wanted.get(e.get("name", ""))
        if key is None or e.get("ph") != "X":
            continue
        in_gpu = kinds.get(e["pid"]) == "GPU Process"
        if key == "page main" and kinds.get(e["pid"]) != "Renderer":
            continue
        if key != "page main" and not in_gpu:
            continue
        total[key] += e.get("dur", 0) / 1000.0
        swaps += key == "SwapBuffers"
    total["copy back"] -= total["finish"]  # the readback's time includes the wait
    frames = max(swaps, 1)
    return [f"{swaps / seconds:.1f}", *(f"{total[key] / frames:.1f}" for key in SLICES)]


def stage(page: Page, url: str) -> None:
    page.route(f"{url}/stage.html", lambda r: r.fulfill(body=STAGE_PAGE, content_type="text/html"))
    page.goto(f"{url}/stage.html")
    page.wait_for_function("window.ready === true")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="traced time per case")
    parser.add_argument("--repeats", type=int, default=2, help="runs of each case, alternating")
    args = parser.parse_args()
    lowest = len(LEVELS) - 1
    rows: list[list[str]] = []
    load0 = os.getloadavg()
    with (
        tempfile.TemporaryDirectory() as tmp,
        server_process(free_port(), Path(tmp) / "server.log") as url,
        sync_playwright() as pw,
    ):
        path = next(iter(PATHS))  # the default: SwiftShader in the GPU process
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=PATHS[path])
        cases = ("the page's stage, no robots, no DOM", f"page, level {lowest}")
        for case in [c for _ in range(args.repeats) for c in cases]:
            page = browser.new_page(viewport=VIEWPORT)
            if case.startswith("page"):
                open_page(page, f"{url}/?quality={lowest}")
                page.select_option("#selected-robot", "iiwa7")  # seven joint plots
            else:
                stage(page, url)
            page.wait_for_timeout(WARM_UP_MS)
            rows.append([case, *per_frame(traced(page, args.seconds), args.seconds)])
            print(" | ".join(rows[-1]), flush=True)
            page.close()
        browser.close()
    load1 = os.getloadavg()
    header = ["what", "presented frames/s", *(f"{k} ms/frame" for k in SLICES)]
    notes = (
        f"Headless Chromium (`{CHROMIUM}`) in its default path ({path}: SwiftShader in the "
        "GPU process, as in bench/page_fps.py), "
        f"{VIEWPORT['width']}x{VIEWPORT['height']}, the demo cell with TCP trails on and "
        f"iiwa7's plots shown; {args.seconds:g} s traced after a {WARM_UP_MS / 1000:g} s "
        "warm-up, the trace's own overhead included (rates are lower than page_fps.py's). "
        "SwapBuffers, finish, copy back, tile raster and commands: the GPU process's main "
        "thread (finish and copy back are parts of SwapBuffers); page main: the renderer's. "
        f"Per presented frame (SwapBuffers count); each case {args.repeats} times, "
        f"alternating. Load average (1 min) {load0[0]:.2f} before, {load1[0]:.2f} after."
    )
    body = f"{notes}\n\n{markdown_table(header, rows)}\n"
    publish("bench/page_trace.py", "Page frames in Chromium's GPU process, traced", body)


if __name__ == "__main__":
    main()
