"""``kb``: the offline knowledge base, a rule-based stand-in for a VLM (not a VLM).

It reads the same messages a VLM would get, finds the machine-readable request block in the user
prompt (```json request), and answers in the same text formats (a JSON plan, a Python program), so
its output goes through exactly the same parsing and validation as a real model's. It is stateless:
the next subgoal is a function of (instruction, objects, previous subgoal, feedback) only.

Coverage: one task family per module under ``families/`` (registered in :mod:`.registry`): stack-in-order,
sweep-half, rope-close-square, slot-pen, stow-book, pour-tea and open-drawer.
"""

from __future__ import annotations

import json

from code_as_monitor.core.errors import VLMError
from code_as_monitor.vlm.backend import KBBackendConfig, VLMResponse
from code_as_monitor.vlm.kb.coder import write_program
from code_as_monitor.vlm.kb.planner import next_subgoal
from code_as_monitor.vlm.messages import Message
from code_as_monitor.vlm.parsing import extract_request
from code_as_monitor.vlm.usage import estimate_prompt_tokens, estimate_tokens

KB_MODEL = "kb-rules-v1"
KB_DESCRIPTION = "kb: a rule-based stand-in for a VLM (not a VLM)"


def compact_answer(answer: dict) -> dict:
    """``answer`` without the fields the schema fills in when absent (a whole object's ``"part": ""``,
    ``"proactive": false``, empty ``"thresholds"``), as the prompt asks: the same validated answer, fewer tokens."""
    out = dict(answer)
    cons = []
    for c in out.get("constraints") or []:
        c = {k: v for k, v in c.items() if not (k == "proactive" and v is False) and not (k == "thresholds" and not v)}
        c["parts"] = [{k: v for k, v in p.items() if not (k == "part" and v == "")} for p in c.get("parts") or []]
        cons.append(c)
    if "constraints" in out:
        out["constraints"] = cons
    return out


def find_request(messages: list[Message]) -> dict:
    """The last ```json request block in the user messages."""
    for m in reversed(messages):
        if m.role == "user":
            req = extract_request(m.text)
            if req is not None:
                return req
    raise VLMError("kb: the prompt has no ```json request block; the kb only answers this project's prompts")


class KBBackend:
    """The knowledge-base backend (see the module docstring)."""

    def __init__(self, config: KBBackendConfig | None = None) -> None:
        self.config = config or KBBackendConfig()

    def complete(self, messages: list[Message], *, purpose: str, schema: dict | None = None) -> VLMResponse:
        """Answer as a model would (``schema`` is not needed: the kb writes the formats the prompts ask for)."""
        request = find_request(messages)
        if purpose == "constraint_generator":
            body = json.dumps(compact_answer(next_subgoal(request)), separators=(",", ":"))  # compact, as asked
            text = f"```json\n{body}\n```" if self.config.fenced else body
        elif purpose == "monitor_coder":
            body = write_program(request)
            text = f"```python\n{body}```" if self.config.fenced else body
        else:
            raise VLMError(f"kb: cannot answer purpose {purpose!r} (knows constraint_generator, monitor_coder)")
        return VLMResponse(
            text=text,
            prompt_tokens=estimate_prompt_tokens(messages),
            completion_tokens=estimate_tokens(text),
            model=KB_MODEL,
            estimated=True,
        )


__all__ = ["KB_DESCRIPTION", "KB_MODEL", "KBBackend", "find_request"]
