from __future__ import annotations

import subprocess
import sys

import pytest

from edge_client.config import ConfigError, load_config

GOOD = """
[server]
url = "https://shore.example.org"
key = "k-123"

[mavlink]
connection = "udpin:0.0.0.0:14550"
baud = 115200

[telemetry]
period_s = 2

[commands]
poll_period_s = 15
arm_before_move = false
ready_timeout_s = 45

[outbox]
path = "/tmp/x.sqlite3"
max_fixes = 500
commit_every = 30

[transport]
kind = "modem"

[transport.modem]
port = "/dev/ttyUSB1"

[readings.water_temp_c]
message = "SCALED_PRESSURE2"
field = "temperature"
scale = 0.01
"""


def write(tmp_path, text: str):
    path = tmp_path / "edge.toml"
    path.write_text(text)
    return path


def test_it_reads_every_table(tmp_path):
    config = load_config(write(tmp_path, GOOD))
    assert config.server.url == "https://shore.example.org"
    assert config.server.key == "k-123"
    assert config.mavlink.baud == 115200
    assert config.telemetry.period_s == 2.0
    assert config.commands.arm_before_move is False
    assert config.commands.ready_timeout_s == 45.0
    assert config.outbox.max_fixes == 500 and config.outbox.commit_every == 30
    assert config.transport.kind == "modem"
    assert config.transport.modem.port == "/dev/ttyUSB1"
    assert config.transport.modem.trigger == "don"
    (reading,) = config.readings
    assert (reading.name, reading.message, reading.field, reading.scale) == (
        "water_temp_c", "SCALED_PRESSURE2", "temperature", 0.01,
    )  # fmt: skip


def test_flags_override_the_file(tmp_path):
    config = load_config(
        write(tmp_path, GOOD),
        {"server": "http://127.0.0.1:8000", "key": "other", "baud": "57600",
         "telemetry_period": "0.5", "poll_period": None, "transport": "http"},
    )  # fmt: skip
    assert config.server.url == "http://127.0.0.1:8000"
    assert config.server.key == "other"
    assert config.mavlink.baud == 57600
    assert config.telemetry.period_s == 0.5
    assert config.commands.poll_period_s == 15.0
    assert config.transport.kind == "http"


def test_flags_alone_are_enough():
    config = load_config(None, {"server": "http://h:1", "key": "k", "mavlink": "tcp:h:5760"})
    assert config.mavlink.connection == "tcp:h:5760"
    assert config.outbox.path.endswith("outbox.sqlite3")


def test_key_comes_from_key_file_or_environment(tmp_path, monkeypatch):
    key_file = tmp_path / "key"
    key_file.write_text("from-file\n")
    text = f'[server]\nurl = "http://h"\nkey_file = "{key_file}"\n'
    assert load_config(write(tmp_path, text)).server.key == "from-file"
    monkeypatch.setenv("SHORESIDE_EDGE_KEY", "from-env")
    assert load_config(None, {"server": "http://h"}).server.key == "from-env"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[server]\nurl = "http://h"\n', "no vessel key"),
        ('[server]\nkey = "k"\n', "url is required"),
        ('[server]\nurl = "ftp://h"\nkey = "k"\n', "not an http:// or https:// URL"),
        ('[server]\nurl = "http://h"\nkey = "k"\nkee = 1\n', "unknown key 'kee'"),
        ('[sever]\nurl = "http://h"\n', "unknown setting 'sever'"),
        ('[server]\nurl = "http://h"\nkey = "k"\n[mavlink]\nbaud = "fast"\n', "whole number"),
        ('[server]\nurl = "http://h"\nkey = "k"\n[mavlink]\nbaud = true\n', "expected int"),
        ('[server]\nurl = "http://h"\nkey = "k"\n[telemetry]\nperiod_s = 0\n', "greater than zero"),
        ('[server]\nurl = "http://h"\nkey = "k"\n[transport]\nkind = "smoke"\n', "not one of"),
        (
            '[server]\nurl = "http://h"\nkey = "k"\n[commands]\nready_timeout_s = -1\n',
            "ready_timeout_s must be greater than zero",
        ),
        (
            '[server]\nurl = "http://h"\nkey = "k"\n[commands]\narm_before_move = "yes"\n',
            "true or false",
        ),
        (
            '[server]\nurl = "http://h"\nkey = "k"\n[readings.t]\nmessage = "X"\n',
            "needs both message and field",
        ),
        ("[server\n", "not valid TOML"),
        (
            '[server]\nurl = "http://h"\nkey = "k"\n[telemetry]\nencoding = "cbor"\n',
            r"\[telemetry\] encoding: 'cbor' is not one of json, compact",
        ),
        (
            '[server]\nurl = "http://h"\nkey = "k"\n[telemetry]\nchannels = [{step = 1}]\n',
            r"\[telemetry\] channels: a channel table is a list of \{name, step\}",
        ),
        (
            '[server]\nurl = "http://h"\nkey = "k"\n[telemetry]\nchannels = "t"\n',
            r"\[telemetry\] channels: expected a list",
        ),
    ],
)
def test_bad_configs_say_what_is_wrong(tmp_path, text, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write(tmp_path, text))


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="no such file"):
        load_config(tmp_path / "nope.toml")


def test_cli_exits_2_with_the_reason(tmp_path):
    path = write(tmp_path, '[server]\nurl = "http://h"\n')
    result = subprocess.run(
        [sys.executable, "-m", "edge_client", "run", "--config", str(path)],
        capture_output=True, text=True, timeout=30,
    )  # fmt: skip
    assert result.returncode == 2
    assert "bad configuration" in result.stderr and "no vessel key" in result.stderr


def test_the_modem_port_and_log_level_flags(tmp_path):
    path = write(
        tmp_path, '[server]\nurl = "http://h"\nkey = "k"\n[transport.modem]\nbaud = 9600\n'
    )
    config = load_config(
        path, {"transport": "modem", "modem_port": "/dev/ttyS3", "log_level": "debug"}
    )
    assert (config.transport.kind, config.transport.modem.port) == ("modem", "/dev/ttyS3")
    assert config.transport.modem.baud == 9600  # the file's other modem settings stay
    assert config.log_level == "DEBUG"
    assert load_config(None, {"server": "http://h", "key": "k"}).log_level == "INFO"


@pytest.mark.parametrize(
    ("text", "flags", "message"),
    [
        ('log_level = "LOUD"\n', {}, "log_level must be one of"),
        ('server = "h"\n', {"server": "http://h"}, r"\[server\] must be a table"),
        ('transport = "http"\n', {}, r"\[transport\] must be a table"),
        ("[transport]\nmodem = 3\n", {}, r"\[transport.modem\] must be a table"),
        ("[transport]\nmodem = 3\n", {"modem_port": "/dev/x"}, r"\[transport.modem\] must be"),
        ("readings = 1\n", {}, r"\[readings\] must be a table of tables"),
        ("[readings]\nt = 1\n", {}, r"\[readings.t\] must be a table with message"),
        ('[readings.t]\nmessage = "X"\nfield = "f"\nunit = "C"\n', {}, "unknown key.s. unit"),
        ('[readings.t]\nmessage = "temp"\nfield = "f"\n', {}, "not a MAVLink message name"),
        ("[transport]\nretries = -1\n", {}, "cannot be negative"),
        ('[transport]\nkind = "modem"\n[transport.modem]\ntrigger = ""\n', {}, "trigger cannot"),
        ('[outbox]\npath = ""\n', {}, r"\[outbox\] path is required"),
        ('[mavlink]\nconnection = ""\n', {}, r"\[mavlink\] connection is required"),
        ("[mavlink]\nstream_rate_hz = 0\n", {}, "stream_rate_hz must be greater than zero"),
        ('[telemetry]\nperiod_s = "soon"\n', {}, "expected a number"),
        ("[server]\nkey_file = 7\n", {}, "expected a string"),
    ],
)
def test_every_table_is_checked_with_flags_or_not(tmp_path, text, flags, message):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError, match=message):
        load_config(path, {"server": "http://h", "key": "k", **flags})


def test_the_key_never_shows_in_a_repr(tmp_path):
    config = load_config(None, {"server": "http://h", "key": "ssk_secret-123"})
    assert config.server.key == "ssk_secret-123"
    for text in (repr(config.server), repr(config), str(config)):
        assert "ssk_secret-123" not in text
    assert "http://h" in repr(config.server)  # the rest still helps a person debugging


def test_key_file_flag_keeps_the_key_off_the_command_line(tmp_path):
    key_file = tmp_path / "edge.key"
    key_file.write_text("from-flag-file\n")
    config = load_config(None, {"server": "http://h", "key_file": str(key_file)})
    assert config.server.key == "from-flag-file"
    # The flag beats a key written in the config file, as every flag beats the file.
    path = write(tmp_path, '[server]\nurl = "http://h"\nkey = "in-the-file"\n')
    assert load_config(path, {"key_file": str(key_file)}).server.key == "from-flag-file"
    with pytest.raises(ConfigError, match="key_file: cannot read"):
        load_config(None, {"server": "http://h", "key_file": str(tmp_path / "missing")})


def test_cli_takes_key_file_and_says_to_prefer_it_over_key(tmp_path):
    key_file = tmp_path / "edge.key"
    key_file.write_text("k\n")
    help_text = " ".join(subprocess.run(
        [sys.executable, "-m", "edge_client", "run", "--help"],
        capture_output=True, text=True, timeout=30,
    ).stdout.split())  # fmt: skip
    assert "--key-file PATH" in help_text and "prefer --key-file" in help_text
    result = subprocess.run(
        [sys.executable, "-m", "edge_client", "run", "--server", "ftp://h",
         "--key-file", str(key_file)],
        capture_output=True, text=True, timeout=30,
    )  # fmt: skip
    # The key came from the file: what is left wrong is the URL, not a missing key.
    assert result.returncode == 2 and "not an http:// or https:// URL" in result.stderr


def test_compact_fixes_and_their_channel_table(tmp_path):
    text = (
        '[server]\nurl = "http://h"\nkey = "k"\n[telemetry]\nencoding = "compact"\n'
        'channels = [{name = "humidity_pct", step = 0.1}, {name = "depth_m"}]\n'
    )
    telemetry = load_config(write(tmp_path, text)).telemetry
    assert telemetry.encoding == "compact"
    assert [(c.name, c.step) for c in telemetry.channels] == [
        ("humidity_pct", 0.1),
        ("depth_m", 0.01),
    ]


def test_the_sbd_modem_is_off_unless_a_port_is_given(tmp_path):
    sbd = load_config(write(tmp_path, GOOD)).sbd
    assert sbd.port == ""
    assert (sbd.baudrate, sbd.fallback_after_s, sbd.period_s, sbd.mailbox_check) == (
        19200, 300.0, 900.0, True,
    )  # fmt: skip


def test_the_sbd_table(tmp_path):
    text = GOOD + (
        '\n[sbd]\nport = "/dev/ttyUSB2"\nbaudrate = 9600\nfallback_after_s = 60\n'
        "period_s = 1800\nmailbox_check = false\n"
    )
    sbd = load_config(write(tmp_path, text)).sbd
    assert (sbd.port, sbd.baudrate, sbd.fallback_after_s, sbd.period_s, sbd.mailbox_check) == (
        "/dev/ttyUSB2", 9600, 60.0, 1800.0, False,
    )  # fmt: skip


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ('port = "/dev/ttyUSB2"\nperiod_s = 0\n', r"\[sbd\] baudrate and period_s must be"),
        ('port = "/dev/ttyUSB2"\nbaudrate = -1\n', r"\[sbd\] baudrate and period_s must be"),
        ('port = "/dev/ttyUSB2"\nfallback_after_s = -5\n', "fallback_after_s cannot be negative"),
        ('port = "/dev/ttyUSB2"\nmailbox_check = "yes"\n', r"\[sbd\] mailbox_check: expected"),
        ("port = 3\n", r"\[sbd\] port: expected a string"),
        ('port = "/dev/ttyUSB2"\nperiod = 900\n', r"\[sbd\]: unknown key 'period'"),
    ],
)
def test_bad_sbd_settings_say_what_is_wrong(tmp_path, table, message):
    with pytest.raises(ConfigError, match=message):
        load_config(write(tmp_path, GOOD + "\n[sbd]\n" + table))
