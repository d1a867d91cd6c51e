"""Headers on every HTTP response that keep the page's data its own.

* ``Content-Security-Policy``: scripts, styles, images and connections from
  this server only (the page's one inline script, its import map, by hash),
  and no framing: an injected or foreign script has nowhere to send data.
* ``Referrer-Policy: no-referrer``: a link followed from the page does not tell
  its address (which may carry ``?token=``).
* ``X-Content-Type-Options: nosniff``: a file is only ever what its type says.
"""

from __future__ import annotations

import base64
import hashlib
import re
from pathlib import Path

from starlette.types import ASGIApp, Message, Receive, Scope, Send

_INLINE_SCRIPT = re.compile(r"<script(?![^>]*\bsrc=)[^>]*>(.*?)</script>", re.S)


def content_security_policy(page: Path) -> str:
    """The policy for ``page`` (index.html): its inline scripts allowed by their hashes."""
    hashes = " ".join(
        "'sha256-" + base64.b64encode(hashlib.sha256(body.encode()).digest()).decode() + "'"
        for body in _INLINE_SCRIPT.findall(page.read_text(encoding="utf-8"))
    )
    return "; ".join(
        [
            "default-src 'self'",
            # WebAssembly (the meshes' decoder) but no eval of JavaScript text.
            f"script-src 'self' 'wasm-unsafe-eval' {hashes}".strip(),
            "style-src 'self'",
            "img-src 'self' data: blob:",  # textures inside GLB files load as blobs
            "connect-src 'self' blob: data:",
            "worker-src 'self' blob:",
            "object-src 'none'",
            "base-uri 'none'",
            "form-action 'self'",
            "frame-ancestors 'none'",
        ]
    )


class SecurityHeaders:
    """Adds the headers above to every HTTP response."""

    def __init__(self, app: ASGIApp, page: Path) -> None:
        self.app = app
        self.headers = [
            (b"content-security-policy", content_security_policy(page).encode()),
            (b"referrer-policy", b"no-referrer"),
            (b"x-content-type-options", b"nosniff"),
        ]

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message["headers"], *self.headers]}
            await send(message)

        await self.app(scope, receive, with_headers)
