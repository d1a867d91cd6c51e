"""deploy/compose.yaml, part by part (no container engine runs here).

The file is read as compose reads it; HAProxy checks its own configuration;
then every service runs here as compose would start it (same commands, same
variables, the Dockerfile's included), with service names and published
ports mapped to loopback, and a viewer reaches the cell through HAProxy.
"""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import yaml
from websockets.asyncio.client import connect

from tests.cluster._roles import (
    Cluster,
    RedisServer,
    Role,
    all_live,
    health_of,
    stop,
    wait_for,
    watch,
)
from tests.conftest import free_port
from tests.test_dockerfile import dockerfile_cmd_and_env

ROOT = Path(__file__).resolve().parent.parent.parent
DEPLOY = ROOT / "deploy"
HAPROXY = shutil.which("haproxy") or "/usr/sbin/haproxy"
BROKER = "redis://redis:6379/0"


def compose() -> dict[str, Any]:
    """deploy/compose.yaml, anchors and merge keys resolved (as compose does)."""
    loaded: dict[str, Any] = yaml.safe_load((DEPLOY / "compose.yaml").read_text())
    return loaded


def services(role: str) -> dict[str, dict[str, Any]]:
    """The linkview services whose command runs ``role`` (``acquire`` or ``web``)."""
    wanted = (
        ["python", "-m", "server", "acquire"] if role == "acquire" else ["python", "-m", "server"]
    )
    return {
        name: s
        for name, s in compose()["services"].items()
        if s.get("command") == wanted and "build" in s
    }


def environment(service: dict[str, Any]) -> dict[str, str]:
    """A service's variables as compose passes them with nothing set on the host."""
    env = {k: str(v) for k, v in service.get("environment", {}).items()}
    return {k: re.sub(r"\$\{\w+:-([^}]*)\}", r"\1", v) for k, v in env.items()}


def test_compose_runs_redis_two_workers_two_replicas_behind_haproxy() -> None:
    spec = compose()["services"]
    assert spec["redis"]["image"].startswith("redis:")
    workers, replicas = services("acquire"), services("web")
    assert len(workers) == 2 and len(replicas) == 2
    for service in [*workers.values(), *replicas.values()]:
        assert (
            DEPLOY / service["build"]["context"] / "Dockerfile"
        ).resolve() == ROOT / "Dockerfile"
        assert environment(service)["LINKVIEW_BROKER"] == BROKER
    for service in workers.values():
        assert service["healthcheck"] == {"disable": True}, "a worker serves no /api/health"
    lb = spec["lb"]
    assert lb["image"].startswith("haproxy:") and lb["ports"] == ["8000:8000"]
    assert lb["volumes"] == ["./haproxy.cfg:/usr/local/etc/haproxy/haproxy.cfg:ro"]
    _, dockerfile_env = dockerfile_cmd_and_env()
    port = dockerfile_env["LINKVIEW_PORT"]
    backends = re.findall(r"^\s*server (\S+) (\S+)", (DEPLOY / "haproxy.cfg").read_text(), re.M)
    assert sorted(backends) == sorted((name, f"{name}:{port}") for name in replicas)
    assert re.search(r"^\s*bind :8000$", (DEPLOY / "haproxy.cfg").read_text(), re.M)


def test_haproxy_accepts_its_configuration() -> None:
    result = subprocess.run(
        [HAPROXY, "-c", "-f", str(DEPLOY / "haproxy.cfg")], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    assert "Configuration file is valid" in result.stdout + result.stderr


async def test_the_services_as_compose_starts_them_serve_viewers_through_haproxy(
    tmp_path: Path,
) -> None:
    redis = RedisServer(tmp_path / "redis", free_port())
    redis.start()
    roles = Cluster(tmp_path, redis.url, None)
    lb: subprocess.Popen[bytes] | None = None
    _, dockerfile_env = dockerfile_cmd_and_env()
    try:
        web: dict[str, Role] = {}
        for kind in ("acquire", "web"):
            for name, service in services(kind).items():
                port = free_port()
                env = {**dockerfile_env, **environment(service)}
                env["LINKVIEW_BROKER"] = env["LINKVIEW_BROKER"].replace(
                    "redis:6379", f"127.0.0.1:{redis.port}"
                )
                env |= {"LINKVIEW_HOST": "127.0.0.1", "LINKVIEW_PORT": str(port)}
                command = service["command"]
                role = roles.start(name, command[1:], env, port)  # python: this interpreter
                if kind == "web":
                    web[name] = role
        lb_port = free_port()
        config = (
            (DEPLOY / "haproxy.cfg").read_text().replace("bind :8000", f"bind 127.0.0.1:{lb_port}")
        )
        for name, role in web.items():
            config = config.replace(f" {name}:8000", f" 127.0.0.1:{role.port}")
        (tmp_path / "haproxy.cfg").write_text(config)
        with open(tmp_path / "haproxy.log", "wb") as log:
            lb = subprocess.Popen(
                [HAPROXY, "-db", "-f", str(tmp_path / "haproxy.cfg")], stdout=log, stderr=log
            )
        front = Role("lb", lb, tmp_path / "haproxy.log", lb_port)
        body = await wait_for(front, all_live)
        assert body["sources"][0]["name"] == "demo"

        # Two viewers through HAProxy: the WebSocket upgrade passes, each lands on a replica.
        first, second = await asyncio.gather(watch(front.base, 2.0), watch(front.base, 2.0))
        assert first.hello == second.hello and first.frames and second.frames
        url = front.base.replace("http", "ws") + "/ws"
        async with connect(url) as one, connect(url) as two:
            assert json.loads(await one.recv())["type"] == "hello"
            assert json.loads(await two.recv())["type"] == "hello"
            counts = [(await health_of(r))[1]["viewers"] for r in web.values()]
        assert counts == [1, 1], "leastconn spreads the viewers over both replicas"
    finally:
        if lb is not None:
            stop(lb)
        roles.close()
        redis.stop()
