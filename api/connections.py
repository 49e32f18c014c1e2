"""The server's connections: how long one may wait for a request, how many it may hold.

A connection costs the server a file descriptor from accept to close, whatever it sends. Without
limits, clients that open connections and send nothing (or a request head a byte at a time) hold
descriptors until the process reaches its open-file limit, and then nobody's connection is
accepted, ``/health``'s included. uvicorn closes a connection that stays silent after a response
(its keep-alive timeout) but has no clock on a connection's first request nor on a head sent slowly,
and no cap per client address; this module adds them to uvicorn's HTTP protocol (httptools):

- **idle timeout**: a connection without a request in progress that sends nothing for
  ``idle_timeout_s`` after its accept or its previous response is closed (uvicorn's keep-alive
  timer, armed at the accept too);
- **header timeout**: a connection that has not sent a complete request head within
  ``header_timeout_s`` of its accept or of its previous response is answered 408 and closed,
  however many bytes it trickled meanwhile;
- **per client**: a client address's connection beyond ``per_client`` is answered 503 at once and
  closed (0: no cap, for a server behind a proxy, where every connection comes from the proxy);
- **in all**: a new connection beyond ``max_connections`` closes the oldest idle connection (no
  request in progress; ordered by its accept or previous response) instead of being refused, so
  that a flood of idle connections never locks out a client with a request to make; only when
  every connection has a request in progress is the new one answered 503.

The closes are logged per episode, not per connection: one line when an episode begins (the first
shed, refusal or timeout after a quiet spell) and one when it ends (``QUIET_S`` without another),
with its counts.

:func:`descriptor_budget` raises the soft open-file limit to the hard one at start-up and says how
many connections it holds: each connection counts as two descriptors (its socket, and a file its
request may have open: an upload being written, a plot being sent), after a reserve for what the
server holds besides (``RESERVE``: the store's connections, the analysis and validation processes'
pipes, logs) and what it has open already.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import resource
from collections import Counter, OrderedDict
from dataclasses import dataclass
from typing import Any, ClassVar

from uvicorn.config import Config
from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol
from uvicorn.server import ServerState

__all__ = [
    "ConnectionLimits",
    "DescriptorBudget",
    "LimitedHttpToolsProtocol",
    "descriptor_budget",
    "protocol_class",
]

log = logging.getLogger("uvicorn.error")

#: Descriptors kept for what the server holds besides its connections: the store's pooled
#: connections, the analysis, validation and calibration processes' pipes, its log.
RESERVE = 256
#: Descriptors a connection may hold: its socket, and a file its request has open.
DESCRIPTORS_PER_CONNECTION = 2
#: A shedding, refusal or timeout episode ends after this long without another [s].
QUIET_S = 2.0


@dataclass(frozen=True)
class ConnectionLimits:
    """How long a connection may wait for its request, and how many the server holds.

    Attributes
    ----------
    header_timeout_s : float
        Longest time from a connection's accept, or from the end of its previous response, to the end
        of its next request head [s]; then 408 and closed.
    idle_timeout_s : float
        Longest silence of a connection without a request in progress, from its accept or its
        previous response [s]; then closed.
    max_connections : int
        Connections held at once; the next one closes the oldest idle connection.
    per_client : int
        Connections held at once from one client address; the next one is answered 503 (0: no cap).
    """

    header_timeout_s: float = 10.0
    idle_timeout_s: float = 5.0
    max_connections: int = 10_000
    per_client: int = 64

    def __post_init__(self) -> None:
        for name in ("header_timeout_s", "idle_timeout_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} = {getattr(self, name)!r}: expected a positive number of seconds")
        if self.max_connections < 1:
            raise ValueError(f"max_connections = {self.max_connections!r}: expected 1 or more")
        if self.per_client < 0:
            raise ValueError(f"per_client = {self.per_client!r}: expected 0 (no cap) or more")


@dataclass(frozen=True)
class DescriptorBudget:
    """The process's open-file limit and the connections it holds.

    Attributes
    ----------
    soft_before, soft, hard : int
        The soft limit at start-up, after raising it, and the hard limit (-1: unlimited).
    open_now : int
        Descriptors open when it was measured.
    connections : int
        Connections that fit: ``(soft - open_now - RESERVE) // DESCRIPTORS_PER_CONNECTION``.
    """

    soft_before: int
    soft: int
    hard: int
    open_now: int
    connections: int

    def summary(self) -> str:
        """One line with the numbers, for the server's start-up."""
        raised = f" (raised from {self.soft_before})" if self.soft != self.soft_before else ""
        hard = "unlimited" if self.hard == resource.RLIM_INFINITY else str(self.hard)
        return (
            f"open-file limit {self.soft}{raised}, hard limit {hard}; {self.open_now} open, {RESERVE} kept "
            f"for the store, files and worker pipes: room for {self.connections} connections at "
            f"{DESCRIPTORS_PER_CONNECTION} descriptors each"
        )


def descriptor_budget() -> DescriptorBudget:
    """Raise the soft open-file limit (RLIMIT_NOFILE) to the hard one; the connections it holds.

    Returns
    -------
    DescriptorBudget
    """
    soft_before, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    target = hard if hard != resource.RLIM_INFINITY else max(soft_before, 1 << 20)
    if soft_before != resource.RLIM_INFINITY and soft_before < target:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
        except (ValueError, OSError):  # a hard limit above what the kernel allows (fs.nr_open)
            pass
    soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    if soft == resource.RLIM_INFINITY:
        soft = 1 << 20
    open_now = _open_descriptors()
    room = (soft - open_now - RESERVE) // DESCRIPTORS_PER_CONNECTION
    return DescriptorBudget(soft_before, soft, hard, open_now, max(0, room))


def _open_descriptors() -> int:
    for folder in ("/proc/self/fd", "/dev/fd"):
        try:
            return len(os.listdir(folder)) - 1  # less the listing's own
        except OSError:
            continue
    return 0


class _Episode:
    """Closes of one kind, logged as one line when they begin and one when they end."""

    def __init__(self, begin: str, end: str) -> None:
        self.begin, self.end = begin, end
        self.count = 0
        self.clients: set[str] = set()
        self.started = self.last = 0.0
        self.timer: asyncio.TimerHandle | None = None

    def note(self, loop: asyncio.AbstractEventLoop, client: str, registry: _Registry) -> None:
        now = loop.time()
        if self.timer is None:
            self.count, self.started = 0, now
            self.clients.clear()
            log.warning(self.begin, _context(registry, client))
            self.timer = loop.call_later(QUIET_S, self._check, loop, registry)
        self.count += 1
        self.last = now
        if len(self.clients) < 10_000:  # a count, not a record of the flood
            self.clients.add(client)

    def _check(self, loop: asyncio.AbstractEventLoop, registry: _Registry) -> None:
        quiet = loop.time() - self.last
        if quiet < QUIET_S:
            self.timer = loop.call_later(QUIET_S - quiet, self._check, loop, registry)
            return
        self.timer = None
        log.warning(
            self.end,
            {
                "count": self.count,
                "clients": len(self.clients),
                "seconds": self.last - self.started,
                **_context(registry, ""),
            },
        )


def _context(registry: _Registry, client: str) -> dict[str, Any]:
    limits = registry.limits
    return {
        "client": client,
        "open": registry.active,
        "max": limits.max_connections,
        "per_client": limits.per_client,
        "header_s": limits.header_timeout_s,
    }


class _Registry:
    """The connections of one server: how many are open, per client address, which are idle."""

    def __init__(self, limits: ConnectionLimits) -> None:
        self.limits = limits
        self.active = 0  # admitted and not closed by this registry
        self.per_client: Counter[str] = Counter()
        self.idle: OrderedDict[LimitedHttpToolsProtocol, None] = OrderedDict()  # oldest first
        self.shedding = _Episode(
            "connections: %(open)d open, the most this server holds (%(max)d): closing the oldest idle "
            "ones to admit new ones",
            "connections: shed %(count)d idle connections in %(seconds).1f s; %(open)d open now",
        )
        self.busy = _Episode(
            "connections: %(open)d open, each with a request in progress: refusing new ones with 503",
            "connections: refused %(count)d connections (every one busy) in %(seconds).1f s; "
            "%(open)d open now",
        )
        self.crowded = _Episode(
            "connections: %(client)s holds %(per_client)d connections, the most from one address: "
            "refusing its next ones with 503",
            "connections: refused %(count)d connections from %(clients)d addresses at their cap in "
            "%(seconds).1f s; %(open)d open now",
        )
        self.slow = _Episode(
            "connections: %(client)s sent no complete request head within %(header_s)g s: closing "
            "such connections with 408",
            "connections: closed %(count)d connections from %(clients)d addresses without a request "
            "head in time, in %(seconds).1f s; %(open)d open now",
        )

    def admit(self, connection: LimitedHttpToolsProtocol) -> str | None:
        """Count a new connection in, shedding the oldest idle one if it is one too many; why it is
        refused instead, or None."""
        limits, host = self.limits, connection.host
        if limits.per_client and self.per_client[host] >= limits.per_client:
            self.crowded.note(connection.loop, host, self)
            return (
                f"this address has {self.per_client[host]} connections open, the most the server "
                "takes from one client: reuse one of them (keep-alive) or close one"
            )
        if self.active >= limits.max_connections:
            victim = self._oldest_idle()
            if victim is None:
                self.busy.note(connection.loop, host, self)
                return (
                    f"the server holds {self.active} connections, its most, each with a request in "
                    "progress: try again shortly"
                )
            self.shedding.note(connection.loop, victim.host, self)
            self.release(victim)
            victim.transport.close()
        self.active += 1
        self.per_client[host] += 1
        connection.counted = True
        return None

    def _oldest_idle(self) -> LimitedHttpToolsProtocol | None:
        while self.idle:
            connection, _ = self.idle.popitem(last=False)
            if connection.counted and not connection.busy and not connection.transport.is_closing():
                return connection
        return None

    def release(self, connection: LimitedHttpToolsProtocol) -> None:
        """Count a connection out (closed by the client or by this server), once."""
        self.idle.pop(connection, None)
        if connection.counted:
            connection.counted = False
            self.active -= 1
            self.per_client[connection.host] -= 1
            if not self.per_client[connection.host]:
                del self.per_client[connection.host]


class LimitedHttpToolsProtocol(HttpToolsProtocol):
    """uvicorn's HTTP/1.1 protocol (httptools) with the limits of a :class:`ConnectionLimits`.

    Made for one server by :func:`protocol_class`, which binds the shared registry.
    """

    registry: ClassVar[_Registry]

    def __init__(
        self,
        config: Config,
        server_state: ServerState,
        app_state: dict[str, Any],
        _loop: asyncio.AbstractEventLoop | None = None,
    ) -> None:
        super().__init__(config, server_state, app_state, _loop)
        self.timeout_keep_alive = self.registry.limits.idle_timeout_s  # type: ignore[assignment]
        self.head_timer: asyncio.TimerHandle | None = None
        self.host = ""
        self.counted = False

    @property
    def busy(self) -> bool:
        """Whether a request is in progress (its head complete, its response not yet)."""
        return self.cycle is not None and not self.cycle.response_complete

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self.host = self.client[0] if self.client else ""
        refusal = self.registry.admit(self)
        if refusal is not None:
            self._answer(503, "Service Unavailable", "too_many_connections", refusal)
            return
        self.timeout_keep_alive_task = self.loop.call_later(
            self.timeout_keep_alive, self.timeout_keep_alive_handler
        )
        self._await_head()

    def connection_lost(self, exc: Exception | None) -> None:
        self.registry.release(self)
        if self.head_timer is not None:
            self.head_timer.cancel()
            self.head_timer = None
        super().connection_lost(exc)

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing() and not self.busy:  # not a pipelined request begun
            self._await_head()

    def _await_head(self) -> None:
        """The connection waits for a request head: idle (first to be shed) and on the header clock."""
        if self.head_timer is not None:
            self.head_timer.cancel()
        self.head_timer = self.loop.call_later(self.registry.limits.header_timeout_s, self._head_late)
        self.registry.idle[self] = None
        self.registry.idle.move_to_end(self)

    def _head_late(self) -> None:
        self.head_timer = None
        if self.busy or self.transport.is_closing():
            return
        self.registry.slow.note(self.loop, self.host, self.registry)
        seconds = self.registry.limits.header_timeout_s
        self._answer(
            408,
            "Request Timeout",
            "request_head_timeout",
            f"no complete request head within {seconds:g} s of the connection's start or of its "
            "previous response",
        )

    def _answer(self, status: int, reason: str, code: str, message: str) -> None:
        """Answer with the service's one error body and close, outside any request."""
        body = json.dumps({"error": {"status": status, "code": code, "message": message}}).encode()
        head = (
            f"HTTP/1.1 {status} {reason}\r\ncontent-type: application/json\r\n"
            f"content-length: {len(body)}\r\nconnection: close\r\n\r\n"
        ).encode()
        self.transport.write(head + body)
        self.transport.close()


def protocol_class(limits: ConnectionLimits) -> type[LimitedHttpToolsProtocol]:
    """uvicorn's HTTP protocol with these limits, for one server (``uvicorn.run(..., http=...)``).

    Parameters
    ----------
    limits : ConnectionLimits

    Returns
    -------
    type
        A subclass of :class:`LimitedHttpToolsProtocol` whose connections share one count.
    """
    return type("LimitedHttpToolsProtocol", (LimitedHttpToolsProtocol,), {"registry": _Registry(limits)})
