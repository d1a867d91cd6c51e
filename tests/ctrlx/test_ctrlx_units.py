"""Pieces of the client without sockets: SSE parsing, FILETIME, paths, values, tokens, Problems."""

from __future__ import annotations

import datetime as dt
import json
import logging
import math
from urllib.parse import unquote

import jwt
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from server.ctrlx import (
    AuthError,
    BadValue,
    Credentials,
    NodeNotFound,
    SseParser,
    Token,
    TokenManager,
    encode_node_path,
    filetime_from_unix,
    unix_from_filetime,
)
from server.ctrlx.problem import ProblemError, problem_for_result, problem_for_status
from server.ctrlx.sse import SseEvent
from server.ctrlx.updates import Keepalive, PlainUpdates, Update, decode_event, plain_updates
from server.ctrlx.values import number_from_data, numbers_from_data, unit_from_data

STREAM = (
    b": comment\r\n"
    b'event: update\r\nid: 1\r\ndata: {"node":"a","timestamp":1,"value":1.5}\r\n\r\n'
    b"event: keepalive\nid: 2\ndata: {}\n\n"
    b"event: update\rdata: line one\rdata: line two\r\r"
    b"data: no event name\n\n"
)


def test_sse_parser_reads_all_line_endings_comments_and_multiline_data() -> None:
    events = SseParser().feed(STREAM)
    assert [(e.event, e.id) for e in events] == [
        ("update", "1"), ("keepalive", "2"), ("update", "2"), ("message", "2"),
    ]  # fmt: skip
    assert events[2].data == "line one\nline two"


@given(st.lists(st.integers(min_value=0, max_value=len(STREAM)), max_size=8))
def test_sse_parser_gives_the_same_events_however_the_bytes_are_split(cuts: list[int]) -> None:
    parser, events, last = SseParser(), [], 0
    for cut in [*sorted(cuts), len(STREAM)]:
        events += parser.feed(STREAM[last:cut])
        last = cut
    assert events == SseParser().feed(STREAM)
    assert not parser.pending


def usual_event(kind: str, event_id: int | None, data: str) -> bytes:
    """An event laid out as data layers send it (event, maybe id, one data line)."""
    id_line = "" if event_id is None else f"id: {event_id}\n"
    return f"event: {kind}\n{id_line}data: {data}\n\n".encode()


ONE_LINE = st.text(st.characters(blacklist_characters="\r\n", blacklist_categories=["Cs"]))
USUAL = st.builds(
    usual_event,
    st.sampled_from(["update", "keepalive", "error", ""]),
    st.none() | st.integers(0, 10**6),
    ONE_LINE,
)
OTHERWISE = st.sampled_from(
    [b": comment\n", b"data: a\ndata: b\n\n", b"id: 9\nevent: late\ndata: x\n\n", b"\n"]
)


@given(st.lists(USUAL | OTHERWISE, max_size=10), st.lists(st.integers(0, 4000), max_size=4))
def test_usual_events_read_as_the_line_rules_read_them(parts: list[bytes], cuts: list[int]) -> None:
    stream = b"".join(parts)
    # With CRLF line ends every line goes through the WHATWG rules one by one.
    reference = SseParser().feed(stream.replace(b"\n", b"\r\n"))
    parser, events, last = SseParser(), [], 0
    for cut in [*sorted(min(c, len(stream)) for c in cuts), len(stream)]:
        events += parser.feed(stream[last:cut])
        last = cut
    assert events == reference


@given(
    st.lists(USUAL | OTHERWISE, max_size=10),
    st.lists(st.integers(0, 4000), max_size=4),
    st.booleans(),
)
def test_the_fast_path_for_update_events_reads_as_feed_reads_them(
    parts: list[bytes], cuts: list[int], at_event_ends: bool
) -> None:
    """Chunk by chunk, ``usual_updates`` gives the data ``feed`` finds in whole update events,
    or None and leaves the chunk to ``feed``; the last id carries on alike."""
    stream = b"".join(parts)
    bounds = [len(b"".join(parts[: k + 1])) for k in range(len(parts))] if at_event_ends else []
    points = sorted({*(min(c, len(stream)) for c in cuts), *bounds, len(stream)})
    reference, fast, last = SseParser(), SseParser(), 0
    for point in points:
        chunk, last = stream[last:point], point
        expected = reference.feed(chunk)
        datas = fast.usual_updates(chunk)
        if datas is None:
            assert fast.feed(chunk) == expected
        else:
            assert expected and all(e.event == "update" for e in expected)
            assert datas == [e.data for e in expected]
    tail = b"event: end\ndata: x\n\n"
    assert fast.feed(tail) == reference.feed(tail)  # same last id, nothing pending


def test_filetime_epochs() -> None:
    assert unix_from_filetime(116_444_736_000_000_000) == 0.0
    # The data-layer description's own event example, 132778212343571969, is in 2021.
    when = dt.datetime.fromtimestamp(unix_from_filetime(132778212343571969), dt.UTC)
    assert (when.year, when.month) == (2021, 10)


@given(st.floats(min_value=0.0, max_value=4e9, allow_nan=False))
def test_filetime_round_trip_to_100_ns(t: float) -> None:
    assert math.isclose(unix_from_filetime(filetime_from_unix(t)), t, abs_tol=1e-7)


@given(st.lists(st.text(min_size=1).filter(lambda s: "/" not in s), min_size=1, max_size=5))
def test_node_paths_encode_each_segment_and_round_trip(segments: list[str]) -> None:
    encoded = encode_node_path("/".join(segments))
    assert encoded.count("/") == len(segments) - 1
    assert [unquote(s) for s in encoded.split("/")] == segments
    assert not set(" ^%#?") & set(encoded.replace("%", "", encoded.count("%")))


def test_special_characters_are_percent_encoded() -> None:
    assert encode_node_path("plc/a^b c%d") == "plc/a%5Eb%20c%25d"


@pytest.mark.parametrize("kind", ["double", "float", "int16", "uint64", "float32"])
def test_scalars(kind: str) -> None:
    assert number_from_data("n", {"type": kind, "value": 3}) == 3.0


@pytest.mark.parametrize("kind", ["arfloat64", "arfloat32", "ardouble", "arfloat"])
def test_arrays_under_current_and_older_names(kind: str) -> None:
    assert numbers_from_data("n", {"type": kind, "value": [1, 2.5]}) == [1.0, 2.5]
    with pytest.raises(BadValue, match="array"):
        number_from_data("n", {"type": kind, "value": [1.0]})


def test_actual_object_gives_position_and_unit() -> None:
    body = {"type": "object", "value": {"actualPos": 12.5, "actualPosUnit": "mm"}}
    assert number_from_data("x", body) == 12.5
    assert unit_from_data(body) == "mm"


@pytest.mark.parametrize(
    "body",
    [
        {"type": "bool8", "value": True},
        {"type": "double", "value": "1.0"},
        {"type": "double", "value": math.nan},
        {"type": "string", "value": "x"},
        {"value": None},
        [1.0],
    ],
)
def test_unusable_values_name_the_node(body: object) -> None:
    with pytest.raises(BadValue, match="my/node"):
        number_from_data("my/node", body)


def token(**claims: float) -> str:
    return jwt.encode(dict(claims), "k" * 32, algorithm="HS256")


def test_tokens_are_renewed_a_share_of_their_life_early_at_most_a_minute() -> None:
    # Planned on our monotonic clock from the moment of arrival (here 10.0), never from exp.
    short = Token.from_jwt(token(iat=100.0, exp=102.0), wall=100.0, mono=10.0)
    assert short.lifetime_s == 2.0
    assert short.renew_at() == pytest.approx(11.6)
    long = Token.from_jwt(token(iat=0.0, exp=3600.0), wall=0.0, mono=0.0)
    assert long.renew_at() == pytest.approx(3540.0)
    assert Token.from_jwt("opaque", wall=5.0, mono=5.0).renew_at() is None
    assert "eyJ" not in repr(short)


def test_a_controller_clock_behind_ours_changes_nothing_but_a_warning() -> None:
    # The device's clock is an hour behind: the token has "expired" by our wall clock.
    behind = Token.from_jwt(token(iat=1000.0, exp=1002.0), wall=4600.0, mono=7.0)
    assert behind.renew_at() == pytest.approx(8.6)
    assert "about 1.0 h behind" in (behind.clock_warning() or "")
    ahead = Token.from_jwt(token(iat=9000.0, exp=9002.0), wall=4600.0, mono=7.0)
    assert ahead.renew_at() == pytest.approx(8.6) and ahead.clock_warning() is None


async def test_a_clock_warning_is_given_once_and_ends_with_a_token_that_fits(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.INFO, "server.ctrlx.auth")
    # Two tokens from a device an hour behind, then one from a device set right.
    issued = iter([token(iat=1000.0, exp=1002.0)] * 2 + [token(iat=4600.0, exp=4602.0)])

    async def fetch() -> str:
        return next(issued)

    async def no_sleep(_s: float) -> None:
        pass

    manager = TokenManager(fetch, wall=lambda: 4600.0, mono=lambda: 7.0, sleep=no_sleep)
    warnings = []
    stale = None
    for _ in range(3):
        stale = await manager.renew(stale)
        warnings.append(manager.warning)
    assert "about 1.0 h behind" in (warnings[0] or "") and warnings[1] == warnings[0]
    assert warnings[2] is None
    said = [r.getMessage() for r in caplog.records if r.name == "server.ctrlx.auth"]
    assert sum("clock skew" in m for m in said) == 1, said
    assert sum("fit our clock again" in m for m in said) == 1, said


def test_tokens_without_a_usable_lifetime_are_renewed_only_on_rejection() -> None:
    backwards = Token.from_jwt(token(iat=5000.0, exp=1000.0), wall=5000.0, mono=0.0)
    assert backwards.lifetime_s is None and backwards.renew_at() is None
    assert "expire before they are issued" in (backwards.clock_warning() or "")
    assert Token.from_jwt(token(iat=5000.0), wall=5000.0, mono=0.0).renew_at() is None
    # No iat: our arrival time stands in for it.
    assert Token.from_jwt(token(exp=5010.0), wall=5000.0, mono=0.0).lifetime_s == 10.0


def test_tiny_lifetimes_are_renewed_no_sooner_than_half_a_second() -> None:
    tiny = Token.from_jwt(token(iat=0.0, exp=0.01), wall=0.0, mono=3.0)
    assert tiny.renew_at() == pytest.approx(3.5)


def test_secrets_stay_out_of_reprs() -> None:
    assert "hunter2" not in repr(Credentials("me", "hunter2"))
    assert "hunter2" not in str(Credentials("me", "hunter2"))


def test_problem_fields_and_subclasses() -> None:
    body = {"type": "about:blank", "title": "Unauthorized", "status": 401,
            "detail": "wrong", "instance": "/x"}  # fmt: skip
    err = problem_for_status(401, body, "fallback")
    assert isinstance(err, AuthError)
    assert (err.status, err.title, err.detail, err.instance) == (401, "Unauthorized", "wrong", "/x")
    assert str(err) == "401 Unauthorized: wrong (/x)"
    assert isinstance(problem_for_result("a", "DL_INVALID_ADDRESS", None), NodeNotFound)
    assert problem_for_status(502, "<html>", "bad gateway").title == "bad gateway"


PLAIN_BODY = st.fixed_dictionaries(
    {
        "node": st.text(max_size=4),
        "timestamp": st.integers(0, 2**63),
        "type": st.sampled_from(["double", "float"]),
        "value": st.floats(allow_nan=False, allow_infinity=False),
    }
)
OTHER_BODY = st.fixed_dictionaries(
    {},
    optional={
        "node": st.text(max_size=4) | st.integers(0, 3),
        "timestamp": st.integers(-1, 2**63) | st.from_regex(r"\A[0-9]{0,20}\Z") | st.none(),
        "type": st.sampled_from(["double", "int32", "arfloat64", "string", "object"]) | st.none(),
        "value": st.floats()
        | st.integers(-(2**70), 2**70)
        | st.booleans()
        | st.none()
        | st.just({"actualPos": 1.5})
        | st.lists(st.floats(), max_size=2),
    },
)


def event_of(kind: str, body: dict[str, object], cut: bool) -> SseEvent:
    data = json.dumps(body)  # NaN and Infinity as literals, as some devices send them
    return SseEvent(kind, None, data[:-1] if cut else data)


PLAIN_UPDATE = st.builds(event_of, st.just("update"), PLAIN_BODY, st.just(False))
UPDATE = st.one_of(
    *[PLAIN_UPDATE] * 6, st.builds(event_of, st.just("update"), OTHER_BODY, st.booleans())
)
"""Update events, mostly of plain numbers (as a publish cycle holds), some of anything."""
PREFIX = "/automation/api/v2/nodes/"


def rows_of(fast: PlainUpdates) -> list[Update]:
    return [Update(*row) for row in zip(fast.nodes, fast.t_sources, fast.values, strict=True)]


@given(st.lists(PLAIN_UPDATE, min_size=1, max_size=4))
def test_a_cycle_of_plain_updates_takes_the_fast_path_and_reads_as_decode_event_reads_it(
    events: list[SseEvent],
) -> None:
    fast = plain_updates([e.data for e in events])
    assert fast is not None, "a cycle of plain float updates must take the fast path"
    assert rows_of(fast) == [decode_event(e, PREFIX) for e in events]


@given(st.lists(UPDATE, min_size=1, max_size=4))
def test_what_the_fast_path_takes_reads_as_decode_event_reads_it(
    events: list[SseEvent],
) -> None:
    """Whatever it does not leave to decode_event (None), it reads as decode_event does."""
    fast = plain_updates([e.data for e in events])
    assume(fast is not None)
    assert rows_of(fast) == [decode_event(e, PREFIX) for e in events]


def test_a_publish_cycle_of_float_updates_takes_the_fast_path() -> None:
    stamp = filetime_from_unix(1.7e9)
    cycle = b"".join(
        b"event: update\nid: %d\n" % i
        + b'data: {"node":"n%d","timestamp":%d,"type":"double","value":%d.5}\n\n' % (i, stamp, i)
        for i in range(7)
    )
    parser = SseParser()
    datas = parser.usual_updates(cycle)
    assert datas == [e.data for e in SseParser().feed(cycle)]
    assert plain_updates(datas) == PlainUpdates(
        [f"n{i}" for i in range(7)], [1.7e9] * 7, [i + 0.5 for i in range(7)]
    )
    assert plain_updates([*datas, '{"node":"n","timestamp":1,"type":"double","value":1}']) is None
    # The last id counts for the events after the fast path, as if ``feed`` had read them.
    assert parser.feed(b"data: x\n\n")[0].id == "6"


def test_events_decode_to_updates_keepalives_and_node_errors() -> None:
    parser = SseParser()
    stamp = filetime_from_unix(1.7e9)
    events = parser.feed(
        b'event: update\ndata: {"node":"a","timestamp":%d,"type":"double","value":2}\n\n'
        b'event: keepalive\ndata: {"timestamp":%d}\n\n'
        b'event: error\ndata: {"title":"DL_INVALID_ADDRESS","status":404,'
        b'"instance":"/automation/api/v2/nodes/b%%5Ec"}\n\n'
        b'event: error\ndata: {"title":"broken","status":500}\n\n' % (stamp, stamp)
    )
    prefix = "/automation/api/v2/nodes/"
    assert decode_event(events[0], prefix) == Update("a", 1.7e9, 2.0)
    assert decode_event(events[1], prefix) == Keepalive(1.7e9)
    error = decode_event(events[2], prefix)
    assert isinstance(error, Update) and error.node == "b^c"
    assert isinstance(error.value, NodeNotFound)
    with pytest.raises(ProblemError, match="broken"):
        decode_event(events[3], prefix)
