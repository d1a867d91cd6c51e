"""20 concurrent 10 000-row /fk requests from a process of its own (so that the viewer
measuring the server meanwhile does not share an interpreter with them).

``python -m tests.e2e._heavy_client PORT TOKEN`` prints a JSON list of
``[status, retry_after]`` pairs.
"""

from __future__ import annotations

import json
import socket
import sys
from concurrent.futures import ThreadPoolExecutor

REQUESTS = 20
ROWS = json.dumps({"joints": [[0.1] * 7] * 10_000}).encode()


def heavy(port: int, token: str) -> tuple[int, str | None]:
    with socket.create_connection(("127.0.0.1", port), timeout=60) as sock:
        sock.sendall(
            (
                f"POST /api/robots/iiwa7/fk HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
                f"Authorization: Bearer {token}\r\nContent-Type: application/json\r\n"
                f"Content-Length: {len(ROWS)}\r\nConnection: close\r\n\r\n"
            ).encode()
            + ROWS
        )
        answer = b""
        while chunk := sock.recv(1 << 16):
            answer += chunk
    head = answer.split(b"\r\n\r\n", 1)[0].decode("latin-1").lower().split("\r\n")
    retry = next((h.split(":", 1)[1].strip() for h in head if h.startswith("retry-after:")), None)
    return int(head[0].split(" ")[1]), retry


if __name__ == "__main__":
    port, token = int(sys.argv[1]), sys.argv[2]
    with ThreadPoolExecutor(REQUESTS) as pool:
        print(json.dumps(list(pool.map(lambda _: heavy(port, token), range(REQUESTS)))))
