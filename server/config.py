"""Settings, read once from the environment (prefix ``LINKVIEW_``) and the command line."""

from __future__ import annotations

from pydantic import Field, SecretStr
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    """Everything that can be configured; deep code gets plain arguments, never this object."""

    model_config = SettingsConfigDict(env_prefix="LINKVIEW_", extra="ignore")

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    ctrlx_url: str | None = None
    """Base URL of the ctrlX device, e.g. ``https://192.168.1.1``; None starts the embedded mock."""
    ctrlx_user: str = "boschrexroth"
    ctrlx_password: SecretStr = SecretStr("boschrexroth")
    poll_interval_s: float = Field(0.02, gt=0.0, le=10.0)
    """Seconds between two reads of the joint nodes (0.02 = 50 Hz)."""
    request_timeout_s: float = Field(5.0, gt=0.0)
    mock_port: int = Field(0, ge=0, le=65535)
    """Port of the embedded mock (0: any free port)."""
