"""The constraint generator (paper eq. 1): next subgoal and its during/upon constraints from a VLM backend.

Inputs are the images of every view, the global instruction, the previous subgoal and the monitor's
feedback, sent once each: the user message is one compact JSON request and the views, stacked into one image
scaled down to fit the low-detail view (512 x 512) and sent at detail "low" (85 tokens on GPT-4o): the planner
needs the scene's layout, not fine detail. The answer is the JSON of :mod:`code_as_monitor.vlm.schemas` (its
JSON schema goes to the backend for servers with structured outputs), validated with pydantic. An invalid
answer is sent back with the validation error up to ``max_retries`` times (each re-ask carries the original
request, the last answer and its error, not the whole conversation), then
:class:`~code_as_monitor.core.errors.VLMOutputError` is raised.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from code_as_monitor.core.constraints import Subgoal
from code_as_monitor.core.errors import ConfigError, VLMOutputError
from code_as_monitor.vlm.backend import VLMBackend, VLMResponse
from code_as_monitor.vlm.messages import Message, TextPart, view_parts
from code_as_monitor.vlm.parsing import dump_request, extract_json
from code_as_monitor.vlm.schemas import (
    ALWAYS_PRESENT,
    SUCCESS_FEEDBACK,
    GeneratorOutput,
    generator_response_schema,
    parse_generator_output,
)
from code_as_monitor.vlm.skills import DEFAULT_SKILLS, skills_markdown
from code_as_monitor.vlm.templates import PROMPT_VERSION, render
from code_as_monitor.vlm.usage import UsageMeter

log = logging.getLogger(__name__)

PURPOSE = "constraint_generator"
GENERATOR_SCHEMA = generator_response_schema()
"""The answer's JSON schema, for servers with structured outputs."""
__all__ = ["PURPOSE", "SUCCESS_FEEDBACK", "ConstraintGenerator"]


def _previous_dict(previous: Subgoal | None) -> dict | None:
    """The previous subgoal as the request gives it (its constraints are not repeated: the feedback names the
    one that stopped it and why)."""
    if previous is None:
        return None
    return {"text": previous.text, "action": previous.action.to_dict() if previous.action else None,
            "done": previous.done}


class ConstraintGenerator:
    """Asks a VLM backend for the next subgoal with its constraints.

    Args:
        backend: any :class:`~code_as_monitor.vlm.backend.VLMBackend`.
        max_retries: re-asks after an invalid answer (so at most ``1 + max_retries`` calls).
        usage: meter to count calls and tokens in (a fresh one when None; see ``self.usage``).
        skills: the policy's skills, name -> description (the simulator's by default).
        prompt_version: version of the prompt template files.
    """

    def __init__(
        self,
        backend: VLMBackend,
        *,
        max_retries: int = 2,
        usage: UsageMeter | None = None,
        skills: dict[str, str] | None = None,
        prompt_version: str = PROMPT_VERSION,
    ) -> None:
        if max_retries < 0:
            raise ConfigError(f"ConstraintGenerator.max_retries must be >= 0, got {max_retries}")
        self.backend = backend
        self.max_retries = max_retries
        self.usage = usage if usage is not None else UsageMeter()
        self.skills = dict(skills if skills is not None else DEFAULT_SKILLS)
        self.prompt_version = prompt_version
        self.last_messages: list[Message] = []
        self.last_response: VLMResponse | None = None
        self.last_output: GeneratorOutput | None = None

    def build_messages(
        self,
        instruction: str,
        observation_images: dict[str, np.ndarray],
        objects: list[str],
        previous: Subgoal | None,
        feedback: str | None,
    ) -> list[Message]:
        """The system and user messages of one request (the user message carries a ```json request block and
        the views, scaled down: :func:`view_parts` with ``downscale``, one low-detail image for all views)."""
        request = {
            "instruction": instruction,
            "objects": list(objects),
            "previous_subgoal": _previous_dict(previous),
            "feedback": feedback,
        }
        system = render("constraint_generator", self.prompt_version, skills=skills_markdown(self.skills))
        user = render("constraint_generator_user", self.prompt_version, request=dump_request(request))
        views = view_parts(observation_images, downscale=True)
        return [Message.system(system), Message("user", [TextPart(user), *views])]

    def next_subgoal(
        self,
        instruction: str,
        observation_images: dict[str, np.ndarray],
        objects: list[str],
        previous: Subgoal | None = None,
        feedback: str | None = None,
    ) -> Subgoal:
        """The next subgoal (``done=True`` when the task is complete).

        Raises:
            VLMOutputError: no valid answer after ``1 + max_retries`` calls (message has the last error).
            VLMError / VLMConfigError: from the backend.
        """
        self.usage.start_subgoal()
        messages = self.build_messages(instruction, observation_images, objects, previous, feedback)
        scene = [o.split("/", 1)[0] for o in objects]
        context = {"objects": scene + [o for o in ALWAYS_PRESENT if o not in scene], "skills": list(self.skills)}
        last_error = ""
        request = messages
        for attempt in range(1 + self.max_retries):
            t0 = time.monotonic()
            resp = self.backend.complete(request, purpose=PURPOSE, schema=GENERATOR_SCHEMA)
            self.usage.record(PURPOSE, resp, time.monotonic() - t0)
            self.last_messages, self.last_response = request, resp
            try:
                out = parse_generator_output(extract_json(resp.text), context)
            except VLMOutputError as exc:
                last_error = str(exc)
                log.info("constraint generator: invalid answer (attempt %d): %s", attempt + 1, last_error)
                repair = render("repair", self.prompt_version, error=last_error, what="JSON object")
                # the original request, the last answer and its error: not the growing conversation
                request = [*messages, Message.assistant(resp.text), Message.user(repair)]
                continue
            self.last_output = out
            return out.to_subgoal()
        raise VLMOutputError(
            f"constraint generator: no valid answer after {1 + self.max_retries} attempt(s); last problem: "
            + last_error.replace("\n", " ")
        )
