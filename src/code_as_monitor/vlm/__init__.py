"""vlm layer."""
