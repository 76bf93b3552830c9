"""Command-line interface (``cam``)."""
