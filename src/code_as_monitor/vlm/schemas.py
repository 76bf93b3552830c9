"""Pydantic schema of the constraint generator's JSON answer (paper eq. 1) and its conversion to core types.

The answer::

    {"subgoal": "pick up the green block", "done": false,
     "action": {"skill": "pick", "args": {"obj": "green_block"}},
     "constraints": [
        {"id": "held_green_block", "text": "...", "phase": "upon", "proactive": false,
         "thresholds": {"max_dist": 0.04},
         "parts": [{"name": "suction tip", "obj": "robot", "part": "tip", "kind": "point"}, ...]}],
     "reasoning": "optional short explanation"}

Validation is contextual: pass ``context={"objects": [...], "skills": [...]}`` to
:func:`parse_generator_output` to reject objects that are not in the scene and unknown skills.
"""

from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator, model_validator

from code_as_monitor.core.constraints import Action, Constraint, Phase, Subgoal, unknown_members
from code_as_monitor.core.elements import ElementKind, ElementSpec
from code_as_monitor.core.errors import VLMOutputError

_ID = r"^[A-Za-z_][A-Za-z0-9_]*$"
SUCCESS_FEEDBACK = "success"
"""The feedback string that reports a completed subgoal (anything else is a failure reason)."""
ALWAYS_PRESENT = ("robot", "table")
"""Objects every scene has: the robot (its end-effector points come from forward kinematics) and the table."""


class PartOut(BaseModel):
    """One entity/part a constraint involves, with the element kind that abstracts it."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1)
    obj: str = Field(min_length=1)
    part: str = ""
    kind: Literal["point", "line", "surface"]

    @field_validator("obj")
    @classmethod
    def _obj_in_scene(cls, v: str, info: ValidationInfo) -> str:
        objects = (info.context or {}).get("objects")
        if objects is not None and v not in objects and v not in ALWAYS_PRESENT:
            raise ValueError(f"object {v!r} is not in the scene; objects are: {', '.join(objects)}")
        return v


class ConstraintOut(BaseModel):
    """One textual constraint."""

    model_config = ConfigDict(extra="forbid")

    id: str = Field(pattern=_ID, max_length=64)
    text: str = Field(min_length=1)
    phase: Literal["during", "upon"]
    proactive: bool = False
    thresholds: dict[str, float] = Field(default_factory=dict)
    parts: list[PartOut] = Field(min_length=1)
    monotone: list[str] = Field(default_factory=list)
    """Parts (part names or objects) read as a set that more members can only help to hold (a rope's beads
    covering a gap): see :attr:`code_as_monitor.core.constraints.Constraint.monotone`."""

    @model_validator(mode="after")
    def _monotone_names_parts(self) -> ConstraintOut:
        bad = unknown_members(self.monotone, self.parts)
        if bad:
            raise ValueError(f"monotone entries {bad} name none of the constraint's parts or their objects")
        return self


class ActionOut(BaseModel):
    """The skill call for the policy."""

    model_config = ConfigDict(extra="forbid")

    skill: str = Field(min_length=1)
    args: dict[str, Any] = Field(default_factory=dict)

    @field_validator("skill")
    @classmethod
    def _known_skill(cls, v: str, info: ValidationInfo) -> str:
        skills = (info.context or {}).get("skills")
        if skills is not None and v not in skills:
            raise ValueError(f"unknown skill {v!r}; available skills: {', '.join(skills)}")
        return v


class GeneratorOutput(BaseModel):
    """The whole answer of the constraint generator."""

    model_config = ConfigDict(extra="forbid")

    subgoal: str = Field(min_length=1)
    done: bool = False
    action: ActionOut | None = None
    constraints: list[ConstraintOut] = Field(default_factory=list)
    reasoning: str = ""

    @model_validator(mode="after")
    def _consistent(self) -> GeneratorOutput:
        if self.done:
            if self.constraints:
                raise ValueError("a completed task ('done': true) must have no constraints")
            return self
        if self.action is None:
            raise ValueError("'action' is required unless 'done' is true")
        if not self.constraints:
            raise ValueError("give at least one constraint for the subgoal")
        ids = [c.id for c in self.constraints]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"constraint ids must be unique; repeated: {', '.join(dup)}")
        return self

    def to_subgoal(self) -> Subgoal:
        """The core :class:`Subgoal` (element ids are left for the painter to fill)."""
        if self.done:
            return Subgoal(text=self.subgoal, constraints=[], action=None, done=True)
        cons = [
            Constraint(
                id=c.id,
                text=c.text,
                phase=Phase.parse(c.phase),
                parts=[ElementSpec(p.name, p.obj, p.part, ElementKind.parse(p.kind)) for p in c.parts],
                thresholds=dict(c.thresholds),
                proactive=c.proactive,
                monotone=list(c.monotone),
            )
            for c in self.constraints
        ]
        assert self.action is not None
        return Subgoal(text=self.subgoal, constraints=cons, action=Action(self.action.skill, dict(self.action.args)))


def format_validation_error(exc: ValidationError) -> str:
    """A compact, model-readable list of what is wrong: ``path: message`` per error."""
    lines = []
    for err in exc.errors(include_url=False):
        loc = ".".join(str(x) for x in err.get("loc", ())) or "(answer)"
        msg = re.sub(r"^Value error, ", "", str(err.get("msg", "")))
        lines.append(f"- {loc}: {msg}")
    return "\n".join(lines)


def parse_generator_output(data: dict[str, Any], context: dict[str, Any] | None = None) -> GeneratorOutput:
    """Validate a parsed JSON answer; raise VLMOutputError listing every problem."""
    try:
        return GeneratorOutput.model_validate(data, context=context or {})
    except ValidationError as exc:
        raise VLMOutputError("the JSON does not match the required schema:\n" + format_validation_error(exc)) from exc


def generator_json_schema() -> dict[str, Any]:
    """JSON schema of the answer (documentation)."""
    return GeneratorOutput.model_json_schema()


def generator_response_schema() -> dict[str, Any]:
    """The answer's JSON schema for structured-output servers, with the rule the pydantic model checks after
    parsing spelled out, so that a server constraining its decoding to the schema cannot produce an answer the
    validator rejects for it: either ``done`` false with an ``action`` and at least one constraint, or ``done``
    true with no constraints."""
    base = GeneratorOutput.model_json_schema()
    props = base["properties"]
    working = {
        "type": "object", "additionalProperties": False,
        "properties": {"subgoal": props["subgoal"], "done": {"type": "boolean", "enum": [False]},
                       "action": {"$ref": "#/$defs/ActionOut"},
                       "constraints": {"type": "array", "items": {"$ref": "#/$defs/ConstraintOut"}, "minItems": 1},
                       "reasoning": props["reasoning"]},
        "required": ["subgoal", "done", "action", "constraints"],
    }
    finished = {
        "type": "object", "additionalProperties": False,
        "properties": {"subgoal": props["subgoal"], "done": {"type": "boolean", "enum": [True]},
                       "action": {"type": "null"}, "constraints": {"type": "array", "maxItems": 0},
                       "reasoning": props["reasoning"]},
        "required": ["subgoal", "done"],
    }
    return {"title": "GeneratorOutput", "type": "object", "anyOf": [working, finished], "$defs": base["$defs"]}


class ProgramOutput(BaseModel):
    """The monitor coder's answer when the server takes a JSON schema: the program's source in one field."""

    model_config = ConfigDict(extra="forbid")

    program: str = Field(min_length=1, description="the Python source of every check_<id>(E, H, t) function")


def program_json_schema() -> dict[str, Any]:
    """JSON schema of the coder's structured answer."""
    return ProgramOutput.model_json_schema()
