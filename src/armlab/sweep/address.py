"""The address of a running Dask scheduler, checked before Dask sees it.

An address is ``[SCHEME://]HOST:PORT``: SCHEME ``tcp`` (the default), ``tls``, ``ws`` or
``wss``; HOST a name, an IPv4 address or an IPv6 address in brackets (``[::1]``); PORT an
integer in 1…65535.  ``tls`` and ``wss`` need a client certificate in Dask's configuration
(``distributed.comm.tls.*``).  Dask's own errors for the same faults are a ``ValueError``, a
``TypeError`` or an abstract class that cannot be instantiated (``ucx`` without its package),
which say nothing of where the address came from; the check here lets the caller name the
option or field.
"""

from __future__ import annotations

import ipaddress
import re

SCHEMES = ("tcp", "tls", "ws", "wss")
"""The schemes a sweep can connect to (``inproc`` reaches only a scheduler inside the same
process; ``ucx`` needs a transport package armlab does not depend on)."""

_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9-]*[A-Za-z0-9])?(\.[A-Za-z0-9]([A-Za-z0-9-]*[A-Za-z0-9])?)*")


def address_problem(address) -> str | None:
    """What is wrong with the scheduler address ``address`` (a sentence), or None if it can be
    tried.  Nothing is resolved or connected to: a well-formed address of a host that is not
    there fails later, as a connection error."""
    if not isinstance(address, str):
        return f"expected an address such as tcp://host:8786, got {address!r}"
    scheme, separator, rest = address.partition("://")
    if not separator:
        scheme, rest = "tcp", address
    if scheme not in SCHEMES:
        return (f"unsupported scheme {scheme!r} (expected one of "
                f"{', '.join(SCHEMES)}: tcp://host:8786)")
    if rest.startswith("["):
        host, bracket, port = rest[1:].partition("]")
        if not bracket:
            return "an IPv6 address needs its closing bracket ([::1]:8786)"
        try:
            ipaddress.IPv6Address(host)
        except ValueError:
            return f"{host!r} is not an IPv6 address"
        if not port.startswith(":"):
            return "no port after the host (expected HOST:PORT, such as tcp://host:8786)"
        port = port[1:]
    else:
        host, colon, port = rest.rpartition(":")
        if not colon:
            return "no port after the host (expected HOST:PORT, such as tcp://host:8786)"
        if ":" in host:
            return "an IPv6 address goes in brackets ([::1]:8786)"
        if not _HOST.fullmatch(host):
            return f"{host!r} is not a host name or an IPv4 address"
    if not (port.isascii() and port.isdigit()) or not 1 <= int(port) <= 65535:
        return f"the port {port!r} is not an integer in 1…65535"
    if scheme in ("tls", "wss") and not _has_client_certificate():
        return (f"{scheme} needs a client certificate in Dask's configuration "
                "(distributed.comm.tls.client.cert), and none is set")
    return None


def _has_client_certificate() -> bool:
    """Whether Dask's configuration gives a client TLS context (what ``Client`` would use)."""
    try:
        from distributed import Security
    except ImportError:
        return True  # the missing package is reported where the client is made
    return Security().get_connection_args("client").get("ssl_context") is not None
