"""Layer 7: experiment runners, executors, metrics and reports."""
