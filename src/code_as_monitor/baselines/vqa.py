"""Yes/no questions about one constraint on ONE current image: the baselines' failure detector.

Two answerers behind :class:`VQA`:

- :class:`VLMVQA`: asks a real VLM backend (``openai``, or ``replay`` of it) through
  :mod:`code_as_monitor.vlm.messages`; every call is counted in a :class:`UsageMeter` (purpose
  ``"vqa"``).
- :class:`~code_as_monitor.baselines.vqa_standin.VQAStandin` (``vqa-standin``): the offline
  rule-based stand-in, NOT a VLM. Its calls are counted in the meter too, with the tokens a VLM
  would have been sent for the same question and image (estimated), so that the cost columns of the
  benchmark compare like with like.
"""

from __future__ import annotations

import re
import time
from typing import Any, Protocol

from code_as_monitor.baselines.vqa_standin import NAME as STANDIN_NAME
from code_as_monitor.baselines.vqa_standin import VQAAnswer, VQAStandin
from code_as_monitor.baselines.vqa_views import question_view
from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.errors import VLMOutputError
from code_as_monitor.core.observation import Observation
from code_as_monitor.vlm.backend import VLMBackend, VLMResponse
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.usage import UsageMeter, estimate_prompt_tokens, estimate_tokens

PURPOSE = "vqa"
SYSTEM = (
    "You are a visual question answering model watching a robot through one camera image. "
    "Answer the question with 'yes' or 'no' as the first word, then one short sentence explaining why."
)
_YES_NO = re.compile(r"^\W*(yes|no)\b", re.I)


def vqa_messages(constraint: Constraint, view_name: str, rgb: Any) -> list[Message]:
    """The request for one yes/no question about ``constraint`` on one image."""
    question = f"Look at the image. Is the following true right now? {constraint.text}"
    return [Message.system(SYSTEM), Message.user(question, {view_name: rgb})]


def parse_yes_no(text: str) -> VQAAnswer:
    """``yes``/``no`` as the first word of ``text``; VLMOutputError otherwise."""
    m = _YES_NO.match(text or "")
    if m is None:
        raise VLMOutputError(f"vqa: expected an answer starting with yes or no, got {text[:80]!r}")
    reason = text[m.end():].strip(" .,:;-\n") or m.group(1).lower()
    return VQAAnswer(m.group(1).lower() == "yes", reason)


class VQA(Protocol):
    """Answers one constraint on one current image."""

    name: str

    def ask(self, constraint: Constraint, obs: Observation) -> VQAAnswer:
        ...


def _view_for(constraint: Constraint, obs: Observation) -> str:
    """The view of ``obs`` the question is asked on (the stand-in's choice, for any camera set), by the stand-in and the
    real VLM alike."""
    return question_view(VQAStandin.view_for(constraint), obs)


class StandinVQA:
    """The rule-based stand-in (not a VLM), metered as if it were one."""

    name = STANDIN_NAME

    def __init__(self, usage: UsageMeter) -> None:
        self.usage = usage
        self.standin = VQAStandin()

    def ask(self, constraint: Constraint, obs: Observation) -> VQAAnswer:
        view = _view_for(constraint, obs)
        ans = self.standin.answer(constraint, obs)
        rgb = obs.views[view].rgb
        msgs = vqa_messages(constraint, view, rgb)
        text = ("yes, " if ans.yes else "no, ") + ans.reason
        self.usage.record(PURPOSE, VLMResponse(text, estimate_prompt_tokens(msgs), estimate_tokens(text),
                                               STANDIN_NAME, estimated=True))
        return ans


class VLMVQA:
    """A real VLM asked yes/no on one image (the DoReMi setting with GPT-4o)."""

    name = "vlm"

    def __init__(self, backend: VLMBackend, usage: UsageMeter) -> None:
        self.backend = backend
        self.usage = usage

    def ask(self, constraint: Constraint, obs: Observation) -> VQAAnswer:
        view = _view_for(constraint, obs)
        rgb = obs.views[view].rgb
        msgs = vqa_messages(constraint, view, rgb)
        t0 = time.monotonic()
        resp = self.backend.complete(msgs, purpose=PURPOSE)
        self.usage.record(PURPOSE, resp, time.monotonic() - t0)
        try:
            return parse_yes_no(resp.text)
        except VLMOutputError:
            # An unparseable answer is not a detection; say so in the reason and treat it as "yes".
            return VQAAnswer(True, f"unparseable VQA answer treated as yes: {resp.text[:60]!r}")


def make_vqa(backend_name: str, backend: VLMBackend, usage: UsageMeter) -> VQA:
    """The stand-in for the offline ``kb`` backend, the real VLM otherwise."""
    if backend_name == "kb":
        return StandinVQA(usage)
    return VLMVQA(backend, usage)


__all__ = ["PURPOSE", "VLMVQA", "VQA", "StandinVQA", "make_vqa", "parse_yes_no", "vqa_messages"]
