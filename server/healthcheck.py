"""``python -m server.healthcheck``: exit 0 when the local server has a live data source.

The Dockerfile's HEALTHCHECK: it asks ``/api/health`` on the port and with
the viewer token of the environment (``LINKVIEW_PORT``, ``LINKVIEW_VIEWER_TOKEN``).
"""

from __future__ import annotations

import os
import sys
import urllib.error
import urllib.request


def main() -> int:
    """0 if /api/health answers 200, else 1 with the reason on stderr."""
    port = os.environ.get("LINKVIEW_PORT", "8000")
    request = urllib.request.Request(f"http://127.0.0.1:{port}/api/health")
    token = os.environ.get("LINKVIEW_VIEWER_TOKEN")
    if token:
        request.add_header("Authorization", f"Bearer {token}")
    try:
        with urllib.request.urlopen(request, timeout=2.5):
            return 0
    except urllib.error.HTTPError as exc:
        print(f"unhealthy: /api/health answered {exc.code}", file=sys.stderr)
    except OSError as exc:
        print(f"unhealthy: {exc}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
