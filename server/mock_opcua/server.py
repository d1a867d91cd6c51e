"""The mock OPC UA server: the simulated machine as Robotics MotionDevices, with faults on demand.

An asyncua Server with the companion models (``address_space``) and the
machine's groups (``robotics``); every ``period_s`` each served variable is
written with the machine's position at that instant (SourceTimestamp: the
simulation's time), and asyncua's subscriptions publish what changed. It
offers the security modes asked for (Basic256Sha256 Sign and SignAndEncrypt
with a certificate it keeps), anonymous and user logins, and the faults a real
server has: sessions dropped (``BadSessionIdInvalid`` from then on), a stall
(nothing answered), a restart (new sessions, namespaces renumbered), a new
certificate.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import hmac
import logging
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from asyncua import ua
from asyncua.common.utils import ServiceError
from asyncua.crypto import cert_gen
from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.server import Server
from asyncua.server.user_managers import UserManager
from asyncua.ua.object_ids import ObjectIds
from asyncua.ua.status_codes import StatusCodes
from cryptography.x509.oid import ExtendedKeyUsageOID

from ..ctrlx.pacing import Pacer
from ..mock_ctrlx import Machine
from ..opcua.security import key_file
from ..opcua.session import SECURITY_MODES, SecurityMode
from .address_space import companion_server
from .robotics import Served, build_robots

log = logging.getLogger(__name__)
# asyncua logs each request it refuses (a dropped session's) as an error: they are the faults.
logging.getLogger("asyncua").setLevel(logging.CRITICAL)

SERVER_URI = "urn:linkview:mock-opcua-server"
PERIOD_S = 0.02
_POLICIES = {
    "None": ua.SecurityPolicyType.NoSecurity,
    "Sign": ua.SecurityPolicyType.Basic256Sha256_Sign,
    "SignAndEncrypt": ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt,
}
_SESSION_ID_INVALID = ua.StatusCode(ua.UInt32(StatusCodes.BadSessionIdInvalid))
_SESSIONLESS = {
    ua.NodeId(ua.Int32(getattr(ObjectIds, f"{name}Request_Encoding_DefaultBinary")))
    for name in ("CreateSession", "ActivateSession", "CloseSession", "FindServers", "GetEndpoints")
}


@dataclass
class MockOptions:
    """How the mock serves: security modes, logins, where it keeps things, how often it writes."""

    security: tuple[SecurityMode, ...] = SECURITY_MODES
    users: Mapping[str, str] = field(default_factory=dict)
    """user -> password; empty: no user logins."""
    anonymous: bool = True
    certificate_dir: Path | None = None
    """Where its certificate and key are kept across starts (None: a temporary folder)."""
    cache: Path | None = None
    """Where the address space is cached (``address_space.companion_server``)."""
    period_s: float = PERIOD_S
    system: str = "linkview-mock"
    subscriptions: bool = True
    """False: CreateSubscription is refused (BadTooManySubscriptions), as by a small server."""


class _Logins(UserManager):
    """Anonymous where allowed, else a user with the right password (compared in constant time)."""

    def __init__(self, options: MockOptions) -> None:
        self.options = options

    def get_user(
        self,
        iserver: Any,
        username: str | None = None,
        password: str | None = None,
        certificate: Any = None,
    ) -> User | None:
        if username is None:
            return User(role=UserRole.User) if self.options.anonymous else None
        expected = self.options.users.get(username)
        if expected is None or not hmac.compare_digest(
            expected.encode(), (password or "").encode()
        ):
            return None
        return User(role=UserRole.User)


class OpcuaMock:
    """A running mock server (``start``), its faults, and ``close``."""

    def __init__(self, machine: Machine, options: MockOptions | None = None) -> None:
        self.machine = machine
        self.options = options or MockOptions()
        self.url = ""
        self.host = "127.0.0.1"
        self.port = 0
        self.boots = 0
        """How often it started; each restart registers one namespace more first (indices move)."""
        self.stalled = False
        self._server: Server | None = None
        self._served = Served()
        self._motion: asyncio.Task[None] | None = None
        self._temporary: tempfile.TemporaryDirectory[str] | None = None
        self._forgetful: set[int] = set()
        self._starting = asyncio.Lock()

    @property
    def certificate_file(self) -> Path:
        """The server's certificate (DER), once security modes other than None are offered."""
        return self._certificate_dir() / "mock-opcua-server.der"

    @property
    def methods(self) -> dict[str, ua.NodeId]:
        """Each group's MoveJoints method."""
        return self._served.methods

    async def start(self, host: str = "127.0.0.1", port: int = 0) -> str:
        """Serve on ``host``:``port`` (0: a free port); returns ``opc.tcp://host:port``."""
        self.host, self.port = host, port
        await self._boot()
        self._motion = asyncio.create_task(self._move(), name="mock-opcua-motion")
        return self.url

    async def ensure_started(self, host: str = "127.0.0.1", port: int = 0) -> str:
        """Start once (on ``port``, or any free one if it is taken meanwhile); the URL."""
        async with self._starting:
            if not self.url:
                try:
                    await self.start(host, port)
                except OSError:
                    log.warning("port %d is taken; the mock OPC UA server takes another", port)
                    await self.start(host, 0)
        return self.url

    async def close(self) -> None:
        """Stop moving and serving."""
        if self._motion is not None:
            self._motion.cancel()
            await asyncio.gather(self._motion, return_exceptions=True)
        await self._shutdown()
        if self._temporary is not None:
            self._temporary.cleanup()

    # -- faults --------------------------------------------------------------------------------

    async def drop_sessions(self) -> None:
        """Forget every session, keeping the connections: their requests get BadSessionIdInvalid."""
        for protocol in self._clients():
            processor = protocol.processor
            if processor is None or processor.session is None:
                continue
            session, processor.session = processor.session, None
            self._forget(processor)
            for pending in list(processor._publish_requests):  # answered as a real server does
                fault = ua.ServiceFault()
                fault.ResponseHeader.ServiceResult = _SESSION_ID_INVALID
                processor.send_response(pending.requesthdr.RequestHandle, pending.seqhdr, fault)
            processor._publish_requests.clear()
            await session.close_session(True)

    def stall(self, stalled: bool = True) -> None:
        """Stop (or resume) answering anything and moving, like a hung controller."""
        self.stalled = stalled
        self._pause_clients()

    async def restart(self) -> None:
        """Stop and start again on the same port: sessions and subscriptions are gone."""
        await self._shutdown()
        await self._boot()

    async def change_certificate(self) -> None:
        """A new certificate (as after a reinstall), then a restart."""
        for path in (self.certificate_file, key_file(self.certificate_file)):
            path.unlink(missing_ok=True)
        await self.restart()

    # -- inside --------------------------------------------------------------------------------

    async def _boot(self) -> None:
        server = await companion_server(self.options.cache)
        await server.set_application_uri(SERVER_URI)
        server.set_server_name("linkview mock OPC UA server")
        server.set_endpoint(f"opc.tcp://{self.host}:{self.port}")
        server.set_security_policy([_POLICIES[mode] for mode in self.options.security])
        if any(mode != "None" for mode in self.options.security):
            await self._certificate(server)
        tokens: list[type] = [ua.AnonymousIdentityToken] if self.options.anonymous else []
        if self.options.users:
            tokens.append(ua.UserNameIdentityToken)
        server.set_identity_tokens(tokens)
        server.iserver.user_manager = _Logins(self.options)
        if not self.options.subscriptions:  # asyncua's own limit: BadTooManySubscriptions
            server.iserver.max_subscriptions = 0
        for k in range(self.boots):  # a restarted server numbers its namespaces anew
            await server.register_namespace(f"urn:linkview:mock-opcua:boot-{k + 1}")
        self._served = await build_robots(server, self.machine, self.options.system)
        await self._write(server)  # no client ever sees the placeholder zeros
        await server.start()
        assert server.bserver is not None
        self.port = server.bserver.port
        self.url = f"opc.tcp://{self.host}:{self.port}"
        self._server, self.boots = server, self.boots + 1
        self._forgetful.clear()

    async def _shutdown(self) -> None:
        server, self._server = self._server, None
        if server is not None:
            with contextlib.suppress(Exception):
                await server.stop()

    def _certificate_dir(self) -> Path:
        if self.options.certificate_dir is not None:
            return self.options.certificate_dir
        if self._temporary is None:
            self._temporary = tempfile.TemporaryDirectory(prefix="mock-opcua-")
        return Path(self._temporary.name)

    async def _certificate(self, server: Server) -> None:
        """Load the kept certificate (made at the first start, or after a change)."""
        certificate = self.certificate_file
        certificate.parent.mkdir(parents=True, exist_ok=True)
        await cert_gen.setup_self_signed_certificate(
            key_file(certificate),
            certificate,
            SERVER_URI,
            self.host,
            [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH],
            {"commonName": "linkview mock OPC UA server"},
        )
        await server.load_certificate(str(certificate))
        await server.load_private_key(str(key_file(certificate)))

    def _clients(self) -> list[Any]:
        server = self._server
        return [] if server is None or server.bserver is None else list(server.bserver.clients)

    def _pause_clients(self) -> None:
        for protocol in self._clients():
            if protocol.transport is None:
                continue
            if self.stalled:
                protocol.transport.pause_reading()
            else:
                protocol.transport.resume_reading()

    def _forget(self, processor: Any) -> None:
        """Make ``processor`` answer BadSessionIdInvalid while it has no session (asyncua would
        answer BadUserAccessDenied, or drop the connection for a publish request)."""
        if id(processor) in self._forgetful:
            return
        self._forgetful.add(id(processor))
        original = processor._process_message

        async def answer(typeid: ua.NodeId, header: Any, sequence: Any, body: Any) -> Any:
            if processor.session is None and typeid not in _SESSIONLESS:
                raise ServiceError(StatusCodes.BadSessionIdInvalid)
            return await original(typeid, header, sequence, body)

        processor._process_message = answer

    async def _move(self) -> None:
        """Write every served variable each period (not while stalled or restarting)."""
        pacer = Pacer(self.options.period_s)
        while True:
            await pacer.wait()
            server = self._server
            if self.stalled:
                self._pause_clients()  # connections made meanwhile hang too
            elif server is not None:
                await self._write(server)

    async def _write(self, server: Server) -> None:
        """The machine's positions (and setpoints) now, stamped with the simulation's time."""
        t = self.machine.now()
        stamp = ua.DateTime.fromtimestamp(t, dt.UTC)
        positions = {g: self.machine.group_positions(g, t) for g in self.machine.groups}
        setpoints: dict[str, Any] = {}
        for node, group, index, setpoint in self._served.values:
            if setpoint and group not in setpoints:
                setpoints[group] = self.machine.group_setpoints(group, t)
            value = (setpoints if setpoint else positions)[group][index]
            variant = ua.Variant(float(value), ua.VariantType.Double)
            # Only the SourceTimestamp: linkview asks for that alone (TimestampsToReturn), and a
            # server honours it; asyncua's would send every timestamp the value holds.
            await server.write_attribute_value(node, ua.DataValue(variant, SourceTimestamp=stamp))
