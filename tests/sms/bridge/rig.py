"""A running bridge between the C&C simulator and the modem simulator, both on pseudo-terminals,
for the end-to-end and fault tests (issue 11, Tests)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

from sms.bridge.process import Bridge, BridgeConfig
from sms.level2.runner import PtyPort, SerialLink
from sms.level2.simulator import CcSimulator, SimConfig, VirtualClock
from sms.modem.simulator import ModemServer, SimulatedModem
from sms.services import authorised_number_authorise
from vessels.models import Vessel

CONTROL = "+61400000001"
QUERY = "+61400000002"
STRANGER = "+61400000009"
FAST_SIM = {"period_s": 1.0, "reply_wait_s": 2.0, "silence_wait_s": 0.02}
# Short everything: a modem that answers at once, retries a second apart.
FAST_MODEM = {"settle_s": 0.02, "wake_timeout_s": 0.3, "reconnect_delay_s": 0.05}


def wait_for(condition: Callable[[], object], timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def authorise(glider: Vessel) -> None:
    authorised_number_authorise(number=CONTROL, vessels=[glider], role="control", name="Skipper")
    authorised_number_authorise(number=QUERY, vessels=[glider], role="query", name="Watcher")


@dataclass
class Rig:
    bridge: Bridge
    modem: SimulatedModem
    server: ModemServer
    cc_port: PtyPort
    thread: threading.Thread

    def cc(self, **config: object) -> CcSimulator:
        """A C&C simulator on the Level 2 pty, enumerated (virtual time: polls when told)."""
        sim = CcSimulator(
            SerialLink(self.cc_port),
            SimConfig(**{**FAST_SIM, **config}),  # type: ignore[arg-type]
            VirtualClock(),
        )
        assert sim.enumerate()
        return sim

    def texts(self) -> list[tuple[str, str]]:
        return [(sms.number, sms.text) for sms in self.modem.sent]


@contextmanager
def running_bridge(
    glider: Vessel,
    modem_where: str = "pty",
    loops: Sequence[tuple[str, Callable[[threading.Event], None]]] = (),
    position_options: Mapping[str, object] | None = None,
    **config: object,
) -> Iterator[Rig]:
    cc_port = PtyPort(timeout=0.01)
    modem = SimulatedModem()
    server = ModemServer(modem, modem_where).start()
    settings = {
        "vessel": glider.slug,
        "level2_port": cc_port.name,
        "modem_port": server.url,
        "poll_period_s": 1,
        "reply_window_s": 5.0,
        "result_timeout_s": 5.0,
        "quarantine_s": 0.5,
        "tick_s": 0.05,
        "reconnect_delay_s": 0.05,
        **config,
    }
    bridge = Bridge(
        BridgeConfig(**settings),  # type: ignore[arg-type]
        vessel=glider,
        modem_config=FAST_MODEM,
        loops=loops,
        sms_options={"retry_base_s": 0.1, "retry_max_s": 0.2},
        position_options=position_options,
    )
    thread = threading.Thread(target=bridge.run, daemon=True)
    thread.start()
    try:
        assert bridge.runner.connected.wait(5)
        yield Rig(bridge, modem, server, cc_port, thread)
    finally:
        bridge.stop()
        thread.join(15)
        server.stop()
        cc_port.close()
    assert not thread.is_alive()
