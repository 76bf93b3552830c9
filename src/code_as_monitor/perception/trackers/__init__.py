"""perception trackers layer."""
