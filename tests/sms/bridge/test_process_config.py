"""run_wg_bridge's configuration: options, WG_* variables and defaults, checked once with clear
errors (a frozen dataclass parsed once)."""

from __future__ import annotations

from pathlib import Path

import pytest
from django.core.management import CommandError, call_command

from sms.bridge.process import REPLY_MARGIN_S, Bridge, BridgeConfig, parse_ports
from sms.bridge.shore_config import ShoreConfig
from sms.management.commands.run_wg_bridge import shore_loops
from vessels.keys import hash_key
from vessels.models import Vessel

PORTS = {"vessel": "glider", "level2_port": "/dev/ttyAMA0", "modem_port": "/dev/ttyUSB2"}


def test_options_win_over_the_environment_which_wins_over_defaults() -> None:
    environ = {"WG_VESSEL": "other", "WG_LEVEL2_PORT": "socket://cc:9000",
               "WG_MODEM_PORT": "/dev/ttyUSB2", "WG_POLL_PERIOD_S": "5",
               "WG_RESULT_TIMEOUT_S": "30", "WG_SENSOR_PORTS": "stasis=4011"}  # fmt: skip
    config = BridgeConfig.from_env(environ, vessel="glider", poll_period_s=None)
    assert (config.vessel, config.level2_port, config.poll_period_s) == (
        "glider",
        "socket://cc:9000",
        5,
    )
    assert (config.result_timeout_s, dict(config.sensor_ports)) == (30.0, {"stasis": 4011})


def test_the_reply_window_defaults_to_one_poll_period_plus_a_margin() -> None:
    assert BridgeConfig(**PORTS, poll_period_s=20).reply_window == 20 + REPLY_MARGIN_S
    assert BridgeConfig(**PORTS, reply_window_s=0).reply_window == 0


@pytest.mark.parametrize(
    ("environ", "message"),
    [
        ({}, "vessel is required"),
        ({**{f"WG_{k.upper()}": v for k, v in PORTS.items()}, "WG_POLL_PERIOD_S": "x"},
         "WG_POLL_PERIOD_S='x' is not a number"),
        ({**{f"WG_{k.upper()}": v for k, v in PORTS.items()}, "WG_POLL_PERIOD_S": "300"},
         "poll_period_s must be 1..255"),
        ({**{f"WG_{k.upper()}": v for k, v in PORTS.items()}, "WG_SHORE_URL": "https://x"},
         "the shore URL and key go together"),
        ({**{f"WG_{k.upper()}": v for k, v in PORTS.items()}, "WG_POWER_COMMAND": "'unclosed"},
         "quotation"),
    ],
)  # fmt: skip
def test_a_bad_setting_is_a_clear_error(environ: dict[str, str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        BridgeConfig.from_env(environ)


def test_sensor_ports_read_as_record_equals_port() -> None:
    assert parse_ports("stasis=4010, ctd=4011") == {"stasis": 4010, "ctd": 4011}
    with pytest.raises(ValueError, match="record=port"):
        parse_ports("stasis")


@pytest.mark.django_db
def test_the_command_names_a_missing_vessel(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("WG_VESSEL", "WG_LEVEL2_PORT", "WG_MODEM_PORT"):
        monkeypatch.delenv(name, raising=False)
    with pytest.raises(CommandError, match="no vessel 'nowhere'"):
        call_command("run_wg_bridge", vessel="nowhere", level2_port="loop://", modem_port="loop://")
    with pytest.raises(CommandError, match="vessel is required"):
        call_command("run_wg_bridge", level2_port="loop://", modem_port="loop://")


@pytest.mark.django_db
def test_the_shore_link_runs_only_when_a_shore_is_configured(glider: Vessel) -> None:
    assert shore_loops(BridgeConfig(**PORTS), glider) == []
    config = BridgeConfig(**PORTS, shore_url="https://shore.example", shore_key="k")
    # The shore link (issue 11 §6) runs its loop in a thread of its own.
    assert [name for name, _loop in shore_loops(config, glider)] == ["shore"]


def test_the_shore_key_never_shows_in_a_config_repr() -> None:
    """A config's repr reaches logs and tracebacks: the vessel key stays out of it."""
    bridge = BridgeConfig(**PORTS, shore_url="https://shore.example", shore_key="s3cret-key")
    shore = ShoreConfig(url="https://shore.example", key="s3cret-key")
    for config in (bridge, shore):
        assert "s3cret-key" not in repr(config) and "shore.example" in repr(config)
    assert (bridge.shore_key, shore.key) == ("s3cret-key", "s3cret-key")


@pytest.mark.django_db
def test_the_shore_key_may_come_from_a_file_kept_out_of_ps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in ("WG_SHORE_URL", "WG_SHORE_KEY"):
        monkeypatch.delenv(name, raising=False)
    key_file = tmp_path / "shore.key"
    key_file.write_text("s3cret-key\n")
    ports = {"level2_port": "loop://", "modem_port": "loop://"}
    # The key read from the file but no URL: the pair is incomplete, so the file was read.
    with pytest.raises(CommandError, match="URL and key go together"):
        call_command("run_wg_bridge", vessel="glider", upstream_key_file=str(key_file), **ports)
    with pytest.raises(CommandError, match="cannot read the key file"):
        call_command("run_wg_bridge", vessel="glider", upstream_key_file="/nonexistent", **ports)


def test_the_position_sms_period_is_off_by_default_and_at_least_a_minute() -> None:
    environ = {f"WG_{k.upper()}": v for k, v in PORTS.items()}
    assert BridgeConfig.from_env(environ).position_sms_period_s == 0
    hourly = BridgeConfig.from_env({**environ, "WG_POSITION_SMS_PERIOD_S": "3600"})
    assert hourly.position_sms_period_s == 3600.0
    assert BridgeConfig.from_env(environ, position_sms_period_s=600.0).position_sms_period_s == 600
    with pytest.raises(ValueError, match="0 \\(off\\) or at least 60"):
        BridgeConfig.from_env({**environ, "WG_POSITION_SMS_PERIOD_S": "6"})
    with pytest.raises(ValueError, match="WG_POSITION_SMS_PERIOD_S='hourly' is not a number"):
        BridgeConfig.from_env({**environ, "WG_POSITION_SMS_PERIOD_S": "hourly"})


@pytest.mark.django_db
def test_the_sms_link_checks_shore_references_with_the_shore_keys_hash(glider: Vessel) -> None:
    """The shore signs its command SMS with the hash of the key this glider presents; the
    bridge's SMS link checks with the hash of the same key, and without one checks nothing."""
    ports = {"vessel": glider.slug, "level2_port": "loop://", "modem_port": "loop://"}
    with_shore = BridgeConfig(**ports, shore_url="https://shore.example", shore_key="s3cret-key")
    # Built, never run: no port is opened until the threads start.
    assert Bridge(with_shore, vessel=glider).sms.shore_key_hash == hash_key("s3cret-key")
    assert Bridge(BridgeConfig(**ports), vessel=glider).sms.shore_key_hash is None
