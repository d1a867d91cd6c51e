"""Settings, read once from the environment (prefix ``LINKVIEW_``) and the command line."""

from __future__ import annotations

from pathlib import Path
from typing import Literal
from urllib.parse import urlsplit

from pydantic import Field, SecretStr, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from .ctrlx import check_base_url, client_ssl
from .mock_ctrlx import HOLD_S


class Settings(BaseSettings):
    """Everything that can be configured; deep code gets plain arguments, never this object."""

    model_config = SettingsConfigDict(env_prefix="LINKVIEW_", extra="ignore")

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    cell: Path | None = None
    """The cell file (TOML, see docs/cell.md); None: the shipped demo cell."""
    allow_commands: bool = False
    """Let the page move robots of real controllers too (embedded mocks always may)."""
    allow_edits: bool = False
    """Let the page change the cell file and save it (docs/commissioning.md)."""
    viewer_token: SecretStr | None = None
    """Required on the page, /ws and /api/* when set (``?token=`` in a link sets a cookie)."""
    allow_origin: list[str] = []
    """Origins besides the server's own whose pages may open /ws and send commands."""
    allow_host: list[str] = []
    """Host names answered besides loopback ones (and, bound beyond loopback, IP addresses)."""
    max_viewers: int = Field(1000, ge=1)
    """Viewers beyond this many are refused with 503."""
    client_timeout_s: float = Field(10.0, gt=0.0)
    """An HTTP client has this long to send a whole request; idle connections close after it."""
    ctrlx_url: str | None = None
    """Base URL of the ctrlX device for a one-source cell, overriding the cell's own source."""
    ctrlx_user: str = "boschrexroth"
    ctrlx_password: SecretStr = SecretStr("boschrexroth")
    ctrlx_api: Literal["v2", "v1"] = "v2"
    """REST API generation: ``v1`` for older firmware (token at api/v1.0, no bulk, no events)."""
    ctrlx_mode: Literal["subscribe", "poll", "get"] = "subscribe"
    """``subscribe`` (SSE, falls back to ``poll``), ``poll`` (bulk reads) or ``get`` (per node)."""
    ctrlx_ca: Path | None = None
    """PEM file of certificates to trust for HTTPS, e.g. the device's self-signed one."""
    insecure: bool = False
    """Skip HTTPS certificate verification (logged as a warning)."""
    poll_interval_s: float = Field(0.02, gt=0.0, le=10.0)
    """Seconds between two samples of the joint nodes (0.02 = 50 Hz), polled or published."""
    keepalive_s: float = Field(1.0, gt=0.0, le=600.0)
    """Subscription keepalive interval; a stream silent 2.5 times as long is reopened."""
    request_timeout_s: float = Field(5.0, gt=0.0)
    sample_cost_s: float = Field(0.0, ge=0.0, le=0.1)
    """CPU seconds spent in vain on every sample: a test knob (environment only) that overloads
    the process on purpose, whatever the machine (tests/e2e/test_overload.py). Leave it at 0."""
    mock_port: int = Field(0, ge=0, le=65535)
    """Port of the embedded mock (0: any free port)."""
    mock_hold_s: float = Field(HOLD_S, ge=0.0, le=3600.0)
    """How long an embedded mock holds a commanded pose before its demo cycle resumes."""
    # Look back (docs/recording.md).
    history_s: float = Field(600.0, gt=0.0, le=86_400.0)
    """Seconds of samples every source keeps for the timeline (memory grows with them, up to a
    bound ``check`` enforces: ``server.history.store.MAX_BYTES``)."""
    record: Path | None = None
    """Folder to record every source to, as MCAP files (one per hour or 500 MB)."""
    replay: Path | None = None
    """An MCAP recording to serve as if live (with --cell: the cell to replay it with)."""
    foxglove_port: int | None = Field(None, ge=0, le=65535)
    """Serve the same data live over Foxglove's WebSocket protocol on this port (same host)."""
    clearance_m: float = Field(0.05, ge=0.0, le=10.0)
    """Links of different robots closer than this are reported (page toggle); 0: not checked."""
    # A cluster (docs/cluster.md).
    broker: str | None = None
    """``redis://HOST:PORT/DB``: run as one role of a cluster sharing this Redis server."""
    broker_password: SecretStr | None = None
    broker_lease_s: float = Field(1.2, ge=0.2, le=60.0)
    """A worker that stops renewing its lease loses its sources to another after this long."""

    @model_validator(mode="after")
    def _one_process_only(self) -> Settings:
        # The look-back features read the history the acquisition feeds in the same process;
        # a replica has no acquisition, and its history stays empty (docs/cluster.md).
        if self.broker is not None:
            given = [
                flag
                for flag, value in (
                    ("--record", self.record),
                    ("--replay", self.replay),
                    ("--foxglove", self.foxglove_port),
                )
                if value is not None
            ]
            if given:
                raise ValueError(f"{', '.join(given)} run in one process, not with --broker yet")
        return self

    @field_validator("ctrlx_url")
    @classmethod
    def _usable_url(cls, url: str | None) -> str | None:
        # A scheme, a host and no credentials (the URL is shown in logs, health and the page).
        if url is not None:
            check_base_url(url)
        return url

    @field_validator("broker")
    @classmethod
    def _broker_url(cls, url: str | None) -> str | None:
        # The password has its own variable: the URL is shown in logs and health.
        if url is None:
            return None
        parts = urlsplit(url.strip())
        if parts.username or parts.password:
            raise ValueError("put the broker's password in LINKVIEW_BROKER_PASSWORD, not the URL")
        if parts.scheme not in ("redis", "rediss") or not parts.hostname:
            raise ValueError(f"broker URL {url!r}: use redis://HOST:PORT/DB")
        try:
            parts.port  # noqa: B018 (only parsing it validates it)
        except ValueError:
            raise ValueError(f"broker URL {url!r} has an invalid port") from None
        if parts.path.strip("/") and not parts.path.strip("/").isdigit():
            raise ValueError(f"broker URL {url!r}: the path is the database number, e.g. /0")
        return url.strip()

    @field_validator("ctrlx_ca")
    @classmethod
    def _readable_ca(cls, ca: Path | None) -> Path | None:
        if ca is not None:
            client_ssl(ca)  # raises ValueError with one clear line
        return ca
