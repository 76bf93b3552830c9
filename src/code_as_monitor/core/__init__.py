"""Layer 0: the typed data model, errors and the registry helper. Imports nothing else of the package."""

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.constraints import Action, Constraint, Phase, Subgoal, Verdict
from code_as_monitor.core.elements import Element, ElementKind, ElementSpec, ElementSupport, color_for
from code_as_monitor.core.errors import CamError
from code_as_monitor.core.observation import Observation, RobotState, View
from code_as_monitor.core.policy import Policy
from code_as_monitor.core.registry import Choice

__all__ = [
    "Action",
    "CamError",
    "CameraModel",
    "Choice",
    "Constraint",
    "Element",
    "ElementKind",
    "ElementSpec",
    "ElementSupport",
    "Observation",
    "Phase",
    "Policy",
    "RobotState",
    "Subgoal",
    "Verdict",
    "View",
    "color_for",
]
