"""Sparkplug B: metric values from an edge node's or a device's births and data messages.

Sparkplug B (Eclipse Foundation) publishes on ``spBv1.0/GROUP/TYPE/EDGE[/DEVICE]``:
a birth certificate (NBIRTH, DBIRTH) lists every metric with its name and, often,
a numeric alias; data messages (NDATA, DDATA) then carry only the metrics that
changed, often by alias alone; a death certificate (NDEATH, DDEATH) says the
node or device is offline (a node's death takes its devices with it). A cell
names a metric as ``spBv1.0/GROUP/EDGE/DEVICE#METRIC NAME`` (see nodes.py).

Payloads are protobuf. google's protobuf runtime parses them against the few
fields read here, declared below with the field numbers of the Sparkplug B
payload (Eclipse Tahu's ``sparkplug_b.proto``) rather than with a generated
module: one schema in one place, and the fields not declared (templates, data
sets, properties) are skipped by the parser. A compressed payload (Tahu's
``SPBV1.0_COMPRESSED``, DEFLATE or GZIP) is inflated to at most MAX_PAYLOAD
bytes, so a small hostile message cannot grow into a large one in memory.
linkview writes nothing to a broker: it sends no rebirth request. Aliases are
learnt from the next birth; until then a value sent by alias alone is named as
waiting for one.
"""

from __future__ import annotations

import math
import zlib
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import DecodeError

NAMESPACE = "spBv1.0"
MAX_PAYLOAD = 4 * 1024 * 1024
"""Largest payload decoded, compressed or inflated (a birth of thousands of metrics fits)."""
COMPRESSED = "SPBV1.0_COMPRESSED"
TYPES = ("NBIRTH", "NDATA", "NDEATH", "DBIRTH", "DDATA", "DDEATH")

# Sparkplug B datatypes: the signed integers (Int8..Int64) by their bits; Double; and the two
# that are no numbers whatever field holds them.
_SIGNED_BITS = {1: 8, 2: 16, 3: 32, 4: 64}
DOUBLE, BOOLEAN, STRING = 10, 11, 12
_VALUE_FIELDS = ("int_value", "long_value", "float_value", "double_value", "boolean_value")


_T = descriptor_pb2.FieldDescriptorProto
METRIC_FIELDS = (
    ("name", 1, _T.TYPE_STRING),
    ("alias", 2, _T.TYPE_UINT64),
    ("timestamp", 3, _T.TYPE_UINT64),
    ("datatype", 4, _T.TYPE_UINT32),
    ("is_historical", 5, _T.TYPE_BOOL),
    ("is_null", 7, _T.TYPE_BOOL),
    ("int_value", 10, _T.TYPE_UINT32),  # 10 to 15: the oneof "value"
    ("long_value", 11, _T.TYPE_UINT64),
    ("float_value", 12, _T.TYPE_FLOAT),
    ("double_value", 13, _T.TYPE_DOUBLE),
    ("boolean_value", 14, _T.TYPE_BOOL),
    ("string_value", 15, _T.TYPE_STRING),
)
PAYLOAD_FIELDS = (
    ("timestamp", 1, _T.TYPE_UINT64),
    ("metrics", 2, _T.TYPE_MESSAGE),  # repeated Metric
    ("seq", 3, _T.TYPE_UINT64),
    ("uuid", 4, _T.TYPE_STRING),
    ("body", 5, _T.TYPE_BYTES),
)
VALUE_FROM = 10
"""A Metric's fields from this number on are its oneof ``value``."""


def _declare(message: Any, fields: tuple[tuple[str, int, int], ...]) -> None:
    """Add ``(name, number, type)`` fields to ``message``: the one message field is the
    repeated Metric; a Metric's fields from VALUE_FROM on are its oneof ``value``."""
    for name, number, kind in fields:
        field = message.field.add(name=name, number=number, type=kind, label=_T.LABEL_OPTIONAL)
        if kind == _T.TYPE_MESSAGE:
            field.label, field.type_name = _T.LABEL_REPEATED, ".linkview.sparkplug.Payload.Metric"
        elif message.name == "Metric" and number >= VALUE_FROM:
            field.oneof_index = 0


def _payload_class() -> Any:
    """The Payload message (the fields linkview reads), built from its description."""
    file = descriptor_pb2.FileDescriptorProto(
        name="linkview_sparkplug_b.proto", package="linkview.sparkplug", syntax="proto2"
    )
    payload = file.message_type.add(name="Payload")
    metric = payload.nested_type.add(name="Metric")
    metric.oneof_decl.add(name="value")
    _declare(metric, METRIC_FIELDS)
    _declare(payload, PAYLOAD_FIELDS)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("linkview.sparkplug.Payload"))


Payload = _payload_class()


class SparkplugError(ValueError):
    """A payload that is not a Sparkplug B payload linkview can read."""


def topic_parts(topic: str) -> tuple[str, str] | None:
    """``(message type, key)`` of a Sparkplug topic, the key without the type
    (``spBv1.0/G/E/D``); None for any other topic."""
    parts = topic.split("/")
    if len(parts) not in (4, 5) or parts[0] != NAMESPACE or parts[2] not in TYPES:
        return None
    return parts[2], "/".join(parts[:2] + parts[3:])


def filters(key: str) -> list[str]:
    """The subscriptions that bring every message about ``key``'s metrics.

    A device's key also follows its edge node: the node's death is the device's.
    """
    namespace, group, edge, *device = key.split("/")
    node = f"{namespace}/{group}/+/{edge}"
    return [node, *(f"{node}/{name}" for name in device)]


def decode(data: bytes | bytearray) -> Any:
    """The Payload in ``data``, inflated if Tahu compressed it; SparkplugError if none."""
    payload = _parsed(data)
    if payload.uuid != COMPRESSED:
        return payload
    algorithm = next((m.string_value for m in payload.metrics if m.name == "algorithm"), "")
    if algorithm.upper() not in ("", "DEFLATE", "GZIP"):
        raise SparkplugError(f"compressed with {algorithm!r}: linkview reads DEFLATE and GZIP")
    inflater = zlib.decompressobj(wbits=47)  # 32 + 15: a zlib or a gzip header, found itself
    try:
        inflated = inflater.decompress(payload.body, MAX_PAYLOAD)
    except zlib.error as exc:
        raise SparkplugError(f"a compressed payload that does not inflate ({exc})") from None
    if inflater.unconsumed_tail:
        raise SparkplugError(f"a compressed payload inflating past {MAX_PAYLOAD >> 20} MiB")
    return _parsed(inflated)


def _parsed(data: bytes | bytearray) -> Any:
    if len(data) > MAX_PAYLOAD:
        raise SparkplugError(f"a payload of {len(data)} bytes (at most {MAX_PAYLOAD} are read)")
    try:
        return Payload.FromString(bytes(data))
    except DecodeError:
        raise SparkplugError("a payload that is not Sparkplug B (protobuf)") from None


def number(metric: Any) -> float:
    """The value of ``metric`` as a finite float; SparkplugError saying what it is instead."""
    if metric.is_null:
        raise SparkplugError("its value is null")
    kind, datatype = metric.WhichOneof("value"), metric.datatype
    if kind not in _VALUE_FIELDS or datatype in (BOOLEAN, STRING) or kind == "boolean_value":
        shown = "no value" if kind is None else kind.removesuffix("_value")
        raise SparkplugError(f"its value is a {shown}, not a number")
    value = getattr(metric, kind)
    if kind in ("int_value", "long_value"):
        bits = _SIGNED_BITS.get(datatype)
        if bits is not None:  # two's complement, whether it was zero-extended or sign-extended
            value &= (1 << bits) - 1
            value -= (value >> (bits - 1)) << bits
    if not math.isfinite(value):
        raise SparkplugError(f"{value} is not a finite number")
    return float(value)


class Devices:
    """What the births, data and deaths of each followed key say of its wanted metrics."""

    def __init__(self, wanted: dict[str, set[str]]) -> None:
        self.wanted = wanted
        """Metric names followed, by key (``spBv1.0/G/E`` or ``spBv1.0/G/E/D``)."""
        self.aliases: dict[str, dict[int, str]] = {}
        self.named: dict[str, set[str]] = {}
        self.bd_seq: dict[str, int] = {}
        """Each edge node's last NBIRTH's ``bdSeq``: its NDEATH (the broker's will) names it."""

    def received(self, kind: str, key: str, data: bytes | bytearray) -> dict[str, dict[str, Any]]:
        """The new values (or errors) of wanted metrics, by key, that one message brings."""
        try:
            payload = decode(data)
        except SparkplugError as exc:
            if key not in self.wanted:
                return {}
            error = SparkplugError(f"{key}: {kind} {exc}")
            return {key: dict.fromkeys(self.wanted[key], error)}
        if kind == "NBIRTH":
            self.bd_seq[key] = _bd_seq(payload)
        if kind.endswith("DEATH"):
            return self._death(kind, key, payload)
        if key not in self.wanted:
            return {}
        return {key: self._values(kind, key, payload)}

    def _values(self, kind: str, key: str, payload: Any) -> dict[str, Any]:
        wanted = self.wanted[key]
        if kind.endswith("BIRTH"):
            self.aliases[key] = {m.alias: m.name for m in payload.metrics if m.HasField("alias")}
            self.named[key] = {m.name for m in payload.metrics}
        aliases = self.aliases.get(key)
        out: dict[str, Any] = {}
        for metric in payload.metrics:
            if metric.is_historical:
                continue  # a past value sent late, not the current one
            name = metric.name or (aliases or {}).get(metric.alias)
            if name is None and aliases is None:
                why = (
                    f"{key}: values come by alias, and no birth certificate came since "
                    "linkview subscribed: they are read from the next one (restart the "
                    "edge node, or send it a rebirth request)"
                )
                return dict.fromkeys(wanted, SparkplugError(why))
            if name in wanted:
                try:
                    out[name] = number(metric)
                except SparkplugError as exc:
                    out[name] = SparkplugError(f"{key}#{name}: {exc}")
        if kind.endswith("BIRTH"):
            named = self.named[key]
            for name in wanted - named:
                out[name] = SparkplugError(
                    f"{key}: its {kind} has no metric {name!r}"
                    f" (it has {len(named)}: {_some(named)})"
                )
        return out

    def _death(self, kind: str, key: str, payload: Any) -> dict[str, dict[str, Any]]:
        seq = _bd_seq(payload)
        if kind == "NDEATH" and self.bd_seq.get(key, seq) != seq:
            return {}  # the will of an earlier session, published after the node was back
        gone = [
            k for k in self.wanted if k == key or (kind == "NDEATH" and k.startswith(key + "/"))
        ]
        out = {}
        for k in {key, *gone}:
            self.aliases.pop(k, None)
            self.named.pop(k, None)
        for k in gone:
            whose = "" if k == key else f" of its edge node {key}"
            error = SparkplugError(f"{k}: offline ({kind}{whose})")
            out[k] = dict.fromkeys(self.wanted[k], error)
        return out


def _bd_seq(payload: Any) -> int:
    """The birth-death sequence number an NBIRTH or NDEATH carries (-1: none)."""
    for metric in payload.metrics:
        kind = metric.WhichOneof("value")
        if metric.name == "bdSeq" and kind in ("int_value", "long_value"):
            return int(getattr(metric, kind))
    return -1


def _some(names: set[str]) -> str:
    shown = sorted(names)[:5]
    return ", ".join(repr(n) for n in shown) + (", ..." if len(names) > 5 else "")


def encoded(metrics: list[tuple[str | None, int | None, float]], seq: int, t_ms: int) -> bytes:
    """A payload of Double metrics ``(name, alias, value)`` (for the embedded mock)."""
    payload = Payload(timestamp=t_ms, seq=seq % 256)
    for name, alias, value in metrics:
        metric = payload.metrics.add(datatype=DOUBLE, double_value=value, timestamp=t_ms)
        if name is not None:
            metric.name = name
        if alias is not None:
            metric.alias = alias
    data: bytes = payload.SerializeToString()
    return data
