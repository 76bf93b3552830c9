"""Layer 7: videos, plots and live views."""
