"""``GET /metrics``: the service in Prometheus' text format (prometheus-client).

Nothing is counted through prometheus-client on the hot path: a collector
reads, at scrape time, the plain counters the runtime keeps anyway.
"""

from __future__ import annotations

from collections.abc import Iterator

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, HistogramMetricFamily
from prometheus_client.registry import Collector

from .. import flood
from ..ctrlx import CtrlxConnector
from ..loop_pacing import loop_pacer
from ..runtime import Runtime
from ..runtime.loop_lag import LoopLag
from ..stream import PROTOCOL_VERSIONS
from ..stream.batches import sample_batch
from ..stream.buckets import Buckets
from . import transformation
from .routes import runtime_of

router = APIRouter()


def _histogram(name: str, doc: str, labels: list[str]) -> HistogramMetricFamily:
    return HistogramMetricFamily(name, doc, labels=labels)


def _add(family: HistogramMetricFamily, values: list[str], buckets: Buckets) -> None:
    family.add_metric(values, buckets.cumulative(), buckets.total)


class RuntimeCollector(Collector):
    """Frames, viewers, sources and timings of one Runtime, read when scraped."""

    def __init__(self, runtime: Runtime, loop_lag: LoopLag | None = None) -> None:
        self.runtime = runtime
        self.loop_lag = loop_lag

    def collect(self) -> Iterator[CounterMetricFamily | GaugeMetricFamily | HistogramMetricFamily]:
        runtime, hub = self.runtime, self.runtime.hub
        published = CounterMetricFamily(
            "linkview_frames_published", "Frames computed and published", labels=["robot"]
        )
        requests = CounterMetricFamily(
            "linkview_datalayer_requests", "Requests sent to the data layer", labels=["source"]
        )
        errors = CounterMetricFamily(
            "linkview_datalayer_errors", "Times the data source failed", labels=["source"]
        )
        logins = CounterMetricFamily(
            "linkview_datalayer_logins", "Logins to the identity manager", labels=["source"]
        )
        age = GaugeMetricFamily(
            "linkview_sample_age_seconds", "Age of the newest sample", labels=["source"]
        )
        live = GaugeMetricFamily(
            "linkview_source_live", "1 while samples arrive", labels=["source"]
        )
        kinematics = _histogram(
            "linkview_kinematics_seconds", "Pose computation per sample", ["source"]
        )
        received = CounterMetricFamily(
            "linkview_samples_received", "Samples the data source sent", labels=["source"]
        )
        processed = CounterMetricFamily(
            "linkview_samples_processed",
            "Samples made into frames (fewer than received: the process cannot keep up)",
            labels=["source"],
        )
        for source_health in runtime.healths():  # a cluster replica's too: from its broker
            name = source_health.name
            received.add_metric([name], source_health.received)
            processed.add_metric([name], source_health.processed)
            for robot, health in source_health.robots.items():
                published.add_metric([robot], health.frames)
            sample_age = source_health.age()
            if sample_age is not None:
                age.add_metric([name], sample_age)
            live.add_metric([name], float(source_health.live))
        for name, source in runtime.sources.items():
            acquisition = source.acquisition
            errors.add_metric([name], acquisition.failures)
            if isinstance(source.connector, CtrlxConnector):  # HTTP requests and logins: ctrlX's
                requests.add_metric([name], source.connector.client.traffic.requests)
                logins.add_metric([name], source.connector.client.tokens.logins)
            _add(kinematics, [name], acquisition.kinematics_time)
        yield from (published, requests, errors, logins, age, live, kinematics, received, processed)
        held = GaugeMetricFamily(
            "linkview_history_samples", "Samples the timeline holds", labels=["source"]
        )
        size = GaugeMetricFamily(
            "linkview_history_bytes", "Memory of the timeline's samples", labels=["source"]
        )
        for name, kept in runtime.history.sources.items():
            held.add_metric([name], len(kept.ring))
            size.add_metric([name], kept.ring.nbytes)
        yield from (held, size)
        yield CounterMetricFamily(
            "linkview_frames_dropped", "Messages skipped for slow viewers", value=hub.dropped
        )
        viewers = GaugeMetricFamily("linkview_viewers", "Viewers connected", labels=["protocol"])
        for protocol in PROTOCOL_VERSIONS:
            viewers.add_metric([str(protocol)], hub.viewers_of(protocol))
        yield viewers
        closed = CounterMetricFamily(
            "linkview_viewers_closed",
            "Viewers closed for sending too many messages or not reading (flood.py)",
            labels=["bound"],
        )
        for bound in ("messages", "queued"):
            closed.add_metric([bound], flood.closed[bound])
        yield closed
        yield CounterMetricFamily(
            "linkview_transformations_refused",
            "fk, ik and move requests answered 503 (too many at once)",
            value=transformation.running.refused,
        )
        batch = sample_batch()
        yield CounterMetricFamily(
            "linkview_samples_computed",
            "Samples made into frames in batches (by linkview_sample_batches: the mean batch)",
            value=batch.sizes,
        )
        yield CounterMetricFamily(
            "linkview_sample_batches",
            "Batches of samples made into frames together (server/stream/batches.py)",
            value=batch.batches,
        )
        delay = _histogram(
            "linkview_sample_to_send_seconds", "From the data layer's sample to each send", []
        )
        _add(delay, [], hub.delay)
        yield delay
        if self.loop_lag is not None:
            lag = _histogram(
                "linkview_event_loop_lag_seconds", "How late the event loop woke (every 0.1 s)", []
            )
            _add(lag, [], self.loop_lag.buckets)
            yield lag
            yield GaugeMetricFamily(
                "linkview_event_loop_lag_newest_seconds",
                "The event loop's newest lateness",
                value=self.loop_lag.newest,
            )
        pacer = loop_pacer()
        yield GaugeMetricFamily(
            "linkview_event_loop_paced",
            "1 while the event loop turns once per tick, flooded by wake-ups (loop_pacing.py)",
            value=int(pacer.paced),
        )
        yield GaugeMetricFamily(
            "linkview_event_loop_wakeups_per_second",
            "How often the event loop's thread was woken, in its newest unpaced measure",
            value=pacer.wakes_per_s,
        )
        yield GaugeMetricFamily(
            "linkview_event_loop_busy_ratio",
            "The share of a core the event loop's thread used, in its newest unpaced measure",
            value=pacer.busy,
        )


@router.get("/metrics", include_in_schema=False)
async def metrics(request: Request) -> Response:
    """Prometheus text format."""
    registry: CollectorRegistry | None = getattr(request.app.state, "metrics", None)
    if registry is None:
        registry = CollectorRegistry()
        lag = getattr(request.app.state, "loop_lag", None)
        registry.register(RuntimeCollector(runtime_of(request), lag))
        request.app.state.metrics = registry
    return Response(generate_latest(registry), media_type=CONTENT_TYPE_LATEST)
