"""Segmenters: the stage registry, interface and factory. Backends (``sim``, ``color``, ``http``) are
imported only by :func:`make_segmenter`."""

from code_as_monitor.perception.segmenters.base import (
    ColorSegmenterConfig,
    HttpSegmenterConfig,
    Segmenter,
    SegmenterConfig,
    SegmentResult,
    SimSegmenterConfig,
    make_segmenter,
)

__all__ = [
    "ColorSegmenterConfig",
    "HttpSegmenterConfig",
    "SegmentResult",
    "Segmenter",
    "SegmenterConfig",
    "SimSegmenterConfig",
    "make_segmenter",
]
