"""Layer 3: constraint elements as visual prompts (the paper's Constraint Painter)."""

from code_as_monitor.painter.painter import Painter, PaintResult, assign_element_ids

__all__ = ["PaintResult", "Painter", "assign_element_ids"]
