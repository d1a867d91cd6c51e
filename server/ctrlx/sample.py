"""The ctrlX follower's samples: ``server.sources.Sample``, and the all-failed check."""

from __future__ import annotations

from ..sources import Sample
from .problem import DataLayerError

__all__ = ["Sample", "checked"]


def checked(sample: Sample) -> Sample:
    """``sample``, unless every node failed: then the source as a whole is unusable."""
    failures = [v for v in sample.values.values() if isinstance(v, Exception)]
    if failures and len(failures) == len(sample.values):
        first = failures[0]
        raise first if isinstance(first, DataLayerError) else DataLayerError(str(first))
    return sample
