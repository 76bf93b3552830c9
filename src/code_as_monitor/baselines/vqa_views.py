"""Which one view a single-image question is asked on, for any camera set.

The baselines' detectors (DoReMi, Inner Monologue) answer from ONE image. The stand-in's rules name the view a
question wants (:meth:`~code_as_monitor.baselines.vqa_standin.VQAStandin.view_for`: the paper's ``top`` view for
counting and the rope, its ``front`` view for everything else). A camera set without that name (two shoulder views,
RLBench's four) gets the view most like it by its geometry: for ``top`` the scene camera whose optical axis points
most steeply down, for ``front`` the one looking most nearly level; ties go to the first view. A camera at the hand
(its centre within :data:`HAND_RADIUS` of the robot's tip on this frame: it moves with the arm and sees the scene
piecemeal) is not a scene view; it is chosen only when no other view exists.

World frame, metres; cameras in OpenCV axes (``T_world_cam[:3, 2]`` is the optical axis in the world).
"""

from __future__ import annotations

import numpy as np

from code_as_monitor.core.camera import CameraModel
from code_as_monitor.core.errors import ObservationError
from code_as_monitor.core.observation import Observation

HAND_RADIUS = 0.25
"""Metres: a camera whose centre is this close to the robot's tip is taken to be on the hand."""
VIEW_KINDS = ("top", "front")
"""The views a question may want: looking down on the workspace, or across it."""


def steepness(camera: CameraModel) -> float:
    """How steeply ``camera`` looks down: the downward (world -z) component of its unit optical axis, -1..1."""
    axis = np.asarray(camera.T_world_cam[:3, 2], dtype=np.float64)
    return float(-axis[2] / max(np.linalg.norm(axis), 1e-12))


def question_view(want: str, obs: Observation) -> str:
    """The name of the view of ``obs`` a question wanting view ``want`` (:data:`VIEW_KINDS`) is asked on: ``want``
    itself when ``obs`` has it, else the most similar scene view (see the module docstring).

    Raises:
        ObservationError: ``obs`` has no view.
    """
    if want in obs.views:
        return want
    names = list(obs.views)
    if not names:
        raise ObservationError("a single-image question needs at least one view; the observation has none")
    tip = obs.tip
    scene = [n for n in names if tip is None
             or float(np.linalg.norm(obs.views[n].camera.T_world_cam[:3, 3] - tip)) > HAND_RADIUS] or names
    steep = [steepness(obs.views[n].camera) for n in scene]
    pick = int(np.argmax(steep)) if want == "top" else int(np.argmin(steep))
    return scene[pick]


__all__ = ["HAND_RADIUS", "VIEW_KINDS", "question_view", "steepness"]
