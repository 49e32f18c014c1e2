"""A loopback TCP proxy in front of the store's server, that can stop it as the service sees it.

The service's tests and ``make bench-kill`` must never stop the machine's
PostgreSQL (others use it). They point the service's store URL at this proxy
instead: :meth:`StoreProxy.stop` closes every connection it carries and
stops listening, so new ones are refused (``ECONNREFUSED``), as a stopped
server's port refuses them; :meth:`StoreProxy.start` listens again on the
same port. To the service this is the database stopped and started again;
the server behind goes on as if nothing happened.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from contextlib import contextmanager, suppress

import sqlalchemy as sa

__all__ = ["StoreProxy", "proxied"]


class StoreProxy:
    """A TCP proxy on a free loopback port to ``target``, one thread per direction of each connection.

    Parameters
    ----------
    target : (str, int)
        The server's address, e.g. ``("127.0.0.1", 5432)``.
    """

    def __init__(self, target: tuple[str, int]) -> None:
        self.target = target
        self.port = 0
        self._listener: socket.socket | None = None
        self._lock = threading.Lock()
        self._carried: set[socket.socket] = set()
        self.connections = 0  # connections carried since it was made
        self.start()

    def start(self) -> None:
        """Listen (again, on the same port): the store is up."""
        listener = socket.socket()
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", self.port))
        listener.listen(128)
        self.port = listener.getsockname()[1]
        self._listener = listener
        threading.Thread(target=self._accept, args=(listener,), daemon=True).start()

    def stop(self) -> None:
        """Close every connection carried and stop listening: the store is down."""
        listener, self._listener = self._listener, None
        if listener is not None:
            with suppress(OSError):
                listener.shutdown(socket.SHUT_RDWR)
            listener.close()
        with self._lock:
            carried, self._carried = self._carried, set()
        for end in carried:
            with suppress(OSError):
                end.shutdown(socket.SHUT_RDWR)
            end.close()

    @property
    def up(self) -> bool:
        """Whether it listens."""
        return self._listener is not None

    def url(self, store_url: str) -> str:
        """``store_url`` (a server's database) through this proxy."""
        url = sa.make_url(store_url).set(host="127.0.0.1", port=self.port)
        return url.render_as_string(hide_password=False)

    def _accept(self, listener: socket.socket) -> None:
        while True:
            try:
                client, _ = listener.accept()
            except OSError:
                return  # stopped
            try:
                server = socket.create_connection(self.target, timeout=5)
            except OSError:
                client.close()
                continue
            server.settimeout(None)
            with self._lock:
                if self._listener is not listener:  # stopped meanwhile
                    client.close()
                    server.close()
                    return
                self._carried |= {client, server}
                self.connections += 1
            for source, sink in ((client, server), (server, client)):
                threading.Thread(target=self._pump, args=(source, sink), daemon=True).start()

    def _pump(self, source: socket.socket, sink: socket.socket) -> None:
        try:
            while data := source.recv(1 << 16):
                sink.sendall(data)
        except OSError:
            pass
        for end in (source, sink):  # the other direction's pump sees its end and stops too
            with suppress(OSError):
                end.shutdown(socket.SHUT_RDWR)
        with self._lock:
            self._carried -= {source, sink}
        source.close()


@contextmanager
def proxied(store_url: str) -> Iterator[tuple[StoreProxy, str]]:
    """A proxy to the server of ``store_url`` and the URL of the same database through it; closed after.

    Parameters
    ----------
    store_url : str
        A PostgreSQL URL.
    """
    url = sa.make_url(store_url)
    proxy = StoreProxy((url.host or "127.0.0.1", url.port or 5432))
    try:
        yield proxy, proxy.url(store_url)
    finally:
        proxy.stop()
