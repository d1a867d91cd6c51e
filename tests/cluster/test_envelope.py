"""Hub messages survive the trip through one Redis message exactly, in order."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from server.cluster import envelope
from server.stream import Message

texts = st.text(  # what orjson writes: any valid UTF-8 but a raw newline
    alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\n"), max_size=40
)
payloads = st.one_of(st.binary(max_size=300), texts, st.lists(texts, max_size=4).map(tuple))
items = st.tuples(
    st.text(min_size=1, max_size=30),
    payloads,
    st.one_of(st.none(), st.floats(allow_nan=False)),
    st.sampled_from([None, 1, 2]),
)


@settings(deadline=None)  # no timing here: a busy machine must not fail it
@given(st.lists(items, max_size=8))
def test_a_batch_unpacks_to_what_was_packed(
    batch: list[tuple[str, object, float | None, int | None]],
) -> None:
    packed = envelope.pack((key, Message(p, t), protocol) for key, p, t, protocol in batch)  # type: ignore[arg-type]
    out = [(key, m.payload, m.t_source, protocol) for key, m, protocol in envelope.unpack(packed)]
    assert out == batch


def test_frames_bytes_travel_as_they_are() -> None:
    frame = bytes(range(256)) * 3
    ((key, message, protocol),) = envelope.unpack(
        envelope.pack([("frames2:line1", Message(frame, 1795268843.57), 2)])
    )
    assert (key, message.payload, message.t_source, protocol) == (
        "frames2:line1",
        frame,
        1795268843.57,
        2,
    )


def test_a_cut_batch_is_refused() -> None:
    packed = envelope.pack([("status:a", Message('{"type":"status"}'), None)])
    with pytest.raises(ValueError, match="runs past the end"):
        list(envelope.unpack(packed[:-3]))
    with pytest.raises(ValueError, match="not a whole item header"):
        list(envelope.unpack(packed + b"\x00\x01"))
