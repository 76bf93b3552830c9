"""perception segmenters layer."""
