"""In Chromium: the page works over protocol 2 with a token in its link; other origins cannot read.

The foreign page is served from another port of 127.0.0.1, which is the same
*site* to the browser: the viewer's cookie goes along with its requests. Only
the Origin check keeps the stream closed to it.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from playwright.sync_api import Browser

from tests.conftest import free_port
from tests.web._browser import open_page, server_process, watch

TOKEN = "viewer-link-secret"
TIMEOUT_MS = 30_000

FOREIGN_PAGE = """<!DOCTYPE html><html><body><script>
window.result = { opened: false, messages: 0, closed: false, fetched: null };
const ws = new WebSocket('WS_URL', ['linkview.2']);
ws.onopen = () => { window.result.opened = true; };
ws.onmessage = () => { window.result.messages += 1; };
ws.onclose = () => { window.result.closed = true; };
fetch('API_URL', { credentials: 'include' })
  .then((r) => r.text()).then((t) => { window.result.fetched = t; })
  .catch(() => { window.result.fetched = 'refused'; });
</script></body></html>"""


@contextmanager
def foreign_site(server_url: str) -> Iterator[str]:
    """Another origin on loopback whose page tries to read the stream and the API."""
    page = FOREIGN_PAGE.replace("WS_URL", server_url.replace("http", "ws") + "/ws")
    page = page.replace("API_URL", server_url + "/api/robots").encode()

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(page)))
            self.end_headers()
            self.wfile.write(page)

        def log_message(self, *args: object) -> None:
            pass

    httpd = ThreadingHTTPServer(("127.0.0.1", free_port()), Handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}/"
    finally:
        httpd.shutdown()
        httpd.server_close()


def test_a_token_link_opens_the_page_over_protocol_2_and_other_origins_read_nothing(
    browser: Browser, tmp_path: Path
) -> None:
    env = {"LINKVIEW_VIEWER_TOKEN": TOKEN}
    with server_process(free_port(), tmp_path / "server.log", env=env) as url:
        context = browser.new_context(viewport={"width": 1280, "height": 800})
        assert context.request.get(f"{url}/").status == 401  # no token yet
        page = context.new_page()

        watched = watch(page)
        open_page(page, f"{url}/?token={TOKEN}&quality=5", TIMEOUT_MS)
        assert "protocol 2" in page.locator("#session").inner_text()
        # The cookie set, the token leaves the address bar (history, bookmarks, screenshots).
        assert page.url == f"{url}/?quality=5", page.url
        cookies = {c["name"]: c for c in context.cookies(url)}
        cookie = cookies["linkview_token"]
        assert cookie["httpOnly"] and cookie["sameSite"] == "Strict"
        page.reload()  # the cookie alone now opens the page, without the token in the link
        page.wait_for_function("() => window.linkview && window.linkview.connected")
        watched.assert_clean()

        with foreign_site(url) as foreign:
            other = context.new_page()
            other.goto(foreign)
            other.wait_for_function(
                "() => window.result.closed && window.result.fetched !== null",
                timeout=TIMEOUT_MS,
            )
            result = other.evaluate("window.result")
        assert result["opened"] is False and result["messages"] == 0
        assert result["fetched"] == "refused", "no CORS: the API answer stays unreadable"
        context.close()
