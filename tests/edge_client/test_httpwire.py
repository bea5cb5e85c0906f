from __future__ import annotations

import random

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from edge_client.httpwire import (
    HttpWireError,
    IncompleteResponse,
    ResponseParser,
    build_request,
)

OK = (
    b'HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nETag: "abc"\r\n'
    b'Content-Length: 17\r\nConnection: close\r\n\r\n{"commands": []}\n'
)


def parse(*chunks: bytes, close: bool = True):
    parser = ResponseParser()
    for chunk in chunks:
        parser.feed(chunk)
    return parser.close() if close else parser.response


def test_build_request_is_exact_http11():
    raw = build_request(
        "POST", "shore.example.org", "/api/v1/boat/telemetry/",
        {"Authorization": "Api-Key k1", "Content-Type": "application/json"}, b'{"fixes":[]}',
    )  # fmt: skip
    assert raw == (
        b"POST /api/v1/boat/telemetry/ HTTP/1.1\r\n"
        b"Host: shore.example.org\r\n"
        b"Connection: close\r\n"
        b"Authorization: Api-Key k1\r\n"
        b"Content-Type: application/json\r\n"
        b"Content-Length: 12\r\n"
        b"\r\n"
        b'{"fixes":[]}'
    )


def test_get_has_no_content_length_and_refuses_header_injection():
    raw = build_request("GET", "h:8000", "/x/", {"If-None-Match": '"e1"'})
    assert raw.endswith(b'If-None-Match: "e1"\r\n\r\n') and b"Content-Length" not in raw
    with pytest.raises(ValueError):
        build_request("GET", "h", "/x/", {"X": "a\r\nEvil: 1"})
    with pytest.raises(ValueError):
        build_request("GET", "h", "/x y/")


def test_it_parses_a_whole_response():
    response = parse(OK, close=False)
    assert response.status == 200
    assert response.headers["etag"] == '"abc"'
    assert response.body == b'{"commands": []}\n'


def test_one_byte_at_a_time_gives_the_same_response():
    assert parse(*[OK[i : i + 1] for i in range(len(OK))]) == parse(OK)


@pytest.mark.parametrize("seed", range(20))
def test_random_splits_give_the_same_response(seed):
    rng = random.Random(seed)
    cuts = sorted(rng.sample(range(1, len(OK)), rng.randint(1, 8)))
    chunks = [OK[a:b] for a, b in zip([0, *cuts], [*cuts, len(OK)], strict=True)]
    assert parse(*chunks) == parse(OK)


def test_304_has_no_body_even_without_length():
    response = parse(b'HTTP/1.1 304 Not Modified\r\nETag: "abc"\r\n\r\n', close=False)
    assert response.status == 304 and response.body == b""


def test_body_until_close_when_there_is_no_length():
    parser = ResponseParser()
    parser.feed(b"HTTP/1.0 200 OK\r\nContent-Type: text/plain\r\n\r\nhello ")
    parser.feed(b"world")
    assert not parser.done
    assert parser.close().body == b"hello world"


def test_chunked_body():
    raw = (
        b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n"
        b"5\r\nhello\r\n6;x=y\r\n world\r\n0\r\n\r\n"
    )
    assert parse(*[raw[i : i + 3] for i in range(0, len(raw), 3)]).body == b"hello world"


def test_modem_chatter_before_the_response_is_skipped():
    parser = ResponseParser()
    parser.feed(b"\r\nCONNECT\r\n")
    parser.feed(OK)
    assert parser.done and parser.response.status == 200
    assert parser.skipped_bytes == len(b"\r\nCONNECT\r\n")


@pytest.mark.parametrize("cut", [0, 10, len(OK) - 20, len(OK) - 1])
def test_a_response_cut_short_is_reported(cut):
    with pytest.raises(IncompleteResponse):
        parse(OK[:cut])


def test_garbage_status_line_is_an_error():
    with pytest.raises(HttpWireError):
        parse(b"HTTP/1.1 abc Nope\r\n\r\n")


@pytest.mark.parametrize(
    ("head", "message"),
    [
        (b"HTTP/1.1 200 OK\r\nno colon here\r\n\r\n", "bad header line"),
        (b"HTTP/1.1 200 OK\r\n Indented: x\r\n\r\n", "bad header line"),
        (b"HTTP/1.1 200 OK\r\nContent-Length: 1e3\r\n\r\n", "bad Content-Length"),
        (b"HTTP/1.1 304 Not Modified\r\nContent-Length: x\r\n\r\n", "bad Content-Length"),
        (b"HTTP/2 200 OK\r\n\r\n", "bad status line"),
        (b"HTTP/1.1\r\n\r\n", "bad status line"),
    ],
)
def test_a_bad_head_says_what_is_wrong(head, message):
    with pytest.raises(HttpWireError, match=message):
        parse(head)


def test_a_head_that_never_ends_is_refused():
    parser = ResponseParser()
    with pytest.raises(HttpWireError, match="response head too large"):
        parser.feed(b"HTTP/1.1 200 OK\r\n" + b"X-Filler: y\r\n" * 2000)


def test_repeated_headers_are_joined_and_the_reason_may_be_missing():
    response = parse(b"HTTP/1.1 204\r\nVary: Accept\r\nvary: Cookie\r\n\r\n", close=False)
    assert (response.status, response.reason) == (204, "")
    assert response.headers == {"vary": "Accept, Cookie"}


def test_chunked_wins_over_content_length():
    raw = (
        b"HTTP/1.1 200 OK\r\nContent-Length: 99\r\nTransfer-Encoding: chunked\r\n\r\n"
        b"2\r\nok\r\n0\r\n\r\n"
    )
    assert parse(raw, close=False).body == b"ok"


@given(st.binary(max_size=300))
@example(b"HTTP/1.1 200 OK\r\nContent-Length: -1\r\n\r\n")
@example(b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n")
@example(b"HTTP/1.1 200\r\n : x\r\n\r\n")
def test_any_bytes_parse_or_raise_the_package_error(data):
    try:
        parse(data)
    except HttpWireError:
        pass
