"""Transports to the shore server behind one small interface (STYLE §11)."""

from __future__ import annotations

from edge_client.config import Config
from edge_client.transports.base import Response, Transport, TransportError

__all__ = ["Response", "Transport", "TransportError", "make_transport"]


def make_transport(config: Config) -> Transport:
    """The transport the config asks for; the rest of the client never knows which one it got."""
    if config.transport.kind == "modem":
        from edge_client.transports.modem import ModemTransport

        return ModemTransport(
            base_url=config.server.url,
            key=config.server.key,
            port=config.transport.modem.port,
            baud=config.transport.modem.baud,
            trigger=config.transport.modem.trigger.encode("ascii"),
            connect_delay_s=config.transport.modem.connect_delay_s,
            timeout_s=config.transport.timeout_s,
            retries=config.transport.retries,
            backoff_s=config.transport.backoff_s,
        )
    from edge_client.transports.http import HttpTransport

    return HttpTransport(
        base_url=config.server.url,
        key=config.server.key,
        timeout_s=config.transport.timeout_s,
        retries=config.transport.retries,
        backoff_s=config.transport.backoff_s,
        ca_bundle=config.transport.ca_bundle or None,
    )
