"""painter layer."""
