"""A Mosquitto broker run by linkview: for an MQTT source's embedded mock, tests and benchmarks.

linkview ships no broker of its own: it starts the installed ``mosquitto``
(Debian's package) on a loopback port with a configuration of its own in a
temporary folder (anonymous access, no persistence, optional password file),
and stops it with the source.
"""

from __future__ import annotations

import asyncio
import contextlib
import getpass
import shutil
import socket
import tempfile
from pathlib import Path

from ..sources import SourceError

CANDIDATES = ("mosquitto", "/usr/sbin/mosquitto")


def mosquitto_binary() -> str | None:
    """The installed Mosquitto broker, if any."""
    for name in CANDIDATES:
        found = shutil.which(name)
        if found:
            return found
    return None


def _free_port(host: str) -> int:
    with socket.socket() as sock:
        sock.bind((host, 0))
        port: int = sock.getsockname()[1]
        return port


class Mosquitto:
    """One broker process: ``await start()``, ``await stop()`` (and start again, same port)."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int | None = None,
        passwords: Path | None = None,
        tls: tuple[Path, Path] | None = None,
    ) -> None:
        self.host = host
        self.port = port or _free_port(host)
        self.passwords = passwords
        """A mosquitto_passwd file: logins required (None: anonymous access)."""
        self.tls = tls
        """(certificate, key) PEM files: the listener speaks TLS (None: plain MQTT)."""
        self._folder = tempfile.TemporaryDirectory(prefix="linkview-mosquitto-")
        self._process: asyncio.subprocess.Process | None = None

    @property
    def url(self) -> str:
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"

    def _config(self) -> Path:
        lines = [
            f"listener {self.port} {self.host}",
            "persistence false",
            "log_dest stderr",
            "log_type error",
            # Started as root, Mosquitto would become the user "mosquitto", who cannot read
            # our temporary files: it stays whoever started it.
            f"user {getpass.getuser()}",
        ]
        if self.tls is not None:
            lines += [f"certfile {self.tls[0]}", f"keyfile {self.tls[1]}"]
        if self.passwords is None:
            lines.append("allow_anonymous true")
        else:
            lines += ["allow_anonymous false", f"password_file {self.passwords}"]
        path = Path(self._folder.name) / "mosquitto.conf"
        path.write_text("\n".join(lines) + "\n")
        return path

    async def start(self, timeout_s: float = 10.0) -> str:
        """Run the broker; returns its ``mqtt://`` address once it accepts connections."""
        binary = mosquitto_binary()
        if binary is None:
            raise SourceError("no MQTT broker: install Mosquitto (Debian: mosquitto) or give a url")
        self._process = await asyncio.create_subprocess_exec(
            binary,
            "-c",
            str(self._config()),
            stdout=asyncio.subprocess.DEVNULL,
            stderr=asyncio.subprocess.PIPE,
        )
        async with asyncio.timeout(timeout_s):
            while True:
                if self._process.returncode is not None:
                    assert self._process.stderr is not None
                    why = (await self._process.stderr.read()).decode(errors="replace").strip()
                    raise SourceError(f"mosquitto on {self.url} stopped: {why[-300:]}")
                with contextlib.suppress(OSError):  # a TCP connection: TLS or not, it listens
                    _, writer = await asyncio.open_connection(self.host, self.port)
                    writer.close()
                    return self.url
                await asyncio.sleep(0.02)

    async def stop(self) -> None:
        """Stop the broker process (its clients see the connection close)."""
        process, self._process = self._process, None
        if process is None or process.returncode is not None:
            return
        process.terminate()
        try:
            await asyncio.wait_for(process.wait(), 5.0)
        except TimeoutError:
            process.kill()
            await process.wait()

    async def close(self) -> None:
        """Stop, and remove the configuration folder."""
        await self.stop()
        self._folder.cleanup()
