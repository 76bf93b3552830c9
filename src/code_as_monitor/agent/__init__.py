"""Layer 5: the closed loop around any policy."""
