"""The monitor coder: subgoal, constraints, annotated views and the element legend -> program source.

The request says each thing once (compact JSON: constraints refer to elements by id, the legend is one short
array per element, named only where its owner does not say what it is) and the annotated views go at the
cheapest detail that keeps their pixels. A request that comes again word for word (a re-planned subgoal) reuses
the program already accepted for it, re-checked; a constraint monitored again in a later subgoal reuses its
accepted check, renumbered (:mod:`~code_as_monitor.planning.check_reuse`), so the model is asked only for the
new constraints.

The answer's code fences are stripped, the source must parse, and then the caller's ``check``
(static validation and path coverage, from the monitor package) must accept it. A rejected program
is sent back with the error up to ``max_retries`` times, then
:class:`~code_as_monitor.core.errors.VLMOutputError` is raised.

Element ids: the painter numbers elements ``0..n-1`` in the order the subgoal's constraint parts
appear, deduplicated by ``(obj, part, kind)`` (:func:`legend_specs`). The coder does not rely on that
order: it maps every constraint part to the element whose owner and kind match it
(:func:`resolve_element_ids`), unless the painter already filled ``Constraint.element_ids``.
"""

from __future__ import annotations

import ast
import json
import logging
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import replace

import numpy as np

from code_as_monitor.core.constraints import Constraint, Subgoal
from code_as_monitor.core.elements import Element, ElementSpec
from code_as_monitor.core.errors import ConfigError, ProgramError, VLMOutputError
from code_as_monitor.planning.check_reuse import KeptCheck, check_key, combine, renumber, split_checks
from code_as_monitor.vlm.backend import VLMBackend, VLMResponse
from code_as_monitor.vlm.messages import Message, TextPart, view_parts
from code_as_monitor.vlm.parsing import dump_request, strip_code_fences
from code_as_monitor.vlm.schemas import program_json_schema
from code_as_monitor.vlm.templates import PROMPT_VERSION, placeholders, render
from code_as_monitor.vlm.usage import UsageMeter

log = logging.getLogger(__name__)

PURPOSE = "monitor_coder"
PROGRAM_SCHEMA = program_json_schema()
"""The structured answer's JSON schema (``{"program": source}``), for servers with structured outputs."""
IMAGE_LINE = " Image: the views, each element drawn with its id."
"""What the coder's system prompt (v4 on) says of the image, when the annotated views are sent."""


def program_text(answer: str) -> str:
    """The program in an answer: the ``program`` field of a JSON answer (structured output), else the text
    without its code fences."""
    text = answer.strip()
    if text.startswith("{"):
        try:
            data = json.loads(text)
        except json.JSONDecodeError:
            data = None
        if isinstance(data, dict) and isinstance(data.get("program"), str):
            return strip_code_fences(data["program"])
    return strip_code_fences(answer)
ProgramCheck = Callable[[str], None]
"""Validates a program; raises ProgramError whose message is sent back to the coder."""


def legend_specs(subgoal: Subgoal) -> list[ElementSpec]:
    """The element specs of ``subgoal`` in id order: constraint parts, deduplicated by (obj, part, kind)."""
    seen: dict[tuple[str, str, str], ElementSpec] = {}
    for c in subgoal.constraints:
        for p in c.parts:
            seen.setdefault((p.obj, p.part, p.kind.value), p)
    return list(seen.values())


def resolve_element_ids(subgoal: Subgoal, elements: list[Element]) -> dict[str, list[int]]:
    """Constraint id -> element ids of its parts (``Constraint.element_ids`` when the painter set them)."""
    index = {(e.owner[0], e.owner[1], e.kind.value): e.id for e in elements}
    known = {e.id for e in elements}
    out: dict[str, list[int]] = {}
    for c in subgoal.constraints:
        if c.element_ids and len(c.element_ids) == len(c.parts):
            bad = [i for i in c.element_ids if i not in known]
            if bad:
                raise ConfigError(f"constraint {c.id!r}: element ids {bad} are not in the legend")
            out[c.id] = list(c.element_ids)
            continue
        ids = []
        for p in c.parts:
            key = (p.obj, p.part, p.kind.value)
            if key not in index:
                raise ConfigError(
                    f"constraint {c.id!r}: no element for part {p.obj}/{p.part or '(whole)'} ({p.kind.value})"
                )
            ids.append(index[key])
        out[c.id] = ids
    return out


def program_defines_checks(source: str, constraint_ids: Iterable[str]) -> None:
    """Static check: ``source`` parses and defines ``check_<id>(E, H, t)`` for every id.

    Raises:
        ProgramError: a syntax error, or the missing / mis-signed functions.
    """
    try:
        tree = ast.parse(source)
    except SyntaxError as exc:
        raise ProgramError(f"syntax error at line {exc.lineno}: {exc.msg}") from None
    defs = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    problems = []
    for cid in constraint_ids:
        name = f"check_{cid}"
        fn = defs.get(name)
        if fn is None:
            problems.append(f"missing function {name}(E, H, t)")
        elif len(fn.args.args) != 3 or fn.args.vararg or fn.args.kwarg or fn.args.kwonlyargs:
            problems.append(f"{name} must take exactly (E, H, t)")
    if problems:
        raise ProgramError("; ".join(problems))


def basic_check(constraint_ids: Iterable[str]) -> ProgramCheck:
    """A minimal ``check``: :func:`program_defines_checks` plus ``compile`` (no execution)."""
    ids = list(constraint_ids)

    def check(source: str) -> None:
        program_defines_checks(source, ids)
        try:
            compile(source, "<monitor program>", "exec")
        except (SyntaxError, ValueError) as exc:
            raise ProgramError(f"does not compile: {exc}") from None

    return check


def owner_text(owner: tuple[str, str]) -> str:
    """``"object/part"`` (``"object"`` for a whole object): how the coder request names an element's owner."""
    return f"{owner[0]}/{owner[1]}" if owner[1] else owner[0]


def legend_row(e: Element) -> list:
    """``[id, kind, "object/part"]``, with the element's name appended only when it says more than its owner
    (``"suction cup tip"`` for ``robot/tip``; not ``"green block"`` for ``green_block``)."""
    row: list = [e.id, e.kind.value, owner_text(e.owner)]
    said = set(re.split(r"[\W_]+", owner_text(e.owner).lower()))
    if set(re.split(r"[\W_]+", e.name.lower())) - said - {""}:
        row.append(e.name)
    return row


def _constraint_entry(c: Constraint, ids: list[int]) -> dict:
    """One constraint of the coder's request; ``monotone``: the ids of its set-like parts, only when it has some
    (the program must read them as possibly missing, :attr:`Constraint.monotone`)."""
    entry: dict = {"id": c.id, "text": c.text, "phase": c.phase.value, "thresholds": dict(c.thresholds),
                   "element_ids": ids}
    if c.monotone:
        entry["monotone"] = c.monotone_ids(ids)
    return entry


def coder_request(subgoal: Subgoal, elements: list[Element], feedback: str | None = None) -> dict:
    """The coder's request: the subgoal, each constraint with its phase, thresholds and the ids of its parts'
    elements (the parts themselves are not repeated: the legend says what each element is), the compact legend
    (:func:`legend_row`) and, after a rejection, why. The action (the subgoal's sentence names it) and
    ``proactive`` (what the agent does with an alarm, not what the program computes) are left out."""
    ids = resolve_element_ids(subgoal, elements)
    request: dict = {
        "subgoal": subgoal.text,
        "constraints": [_constraint_entry(c, ids[c.id]) for c in subgoal.constraints],
        "elements": [legend_row(e) for e in elements],
    }
    if feedback:
        request["feedback"] = feedback
    return request


class MonitorCoder:
    """Asks a VLM backend for the monitor program of a subgoal.

    Args:
        backend: any VLM backend.
        usage: meter to count calls and tokens in (a fresh one when None).
        prompt_version: version of the prompt template files.
        reuse: keep each accepted program under its request (:func:`coder_request`: subgoal, action,
            constraints with thresholds and element ids, legend) and, when the same request comes again (a
            subgoal re-planned word for word after a failure), run ``check`` on the kept program before asking
            the model; the program reads only the elements, so the same request needs the same program. A kept
            program that ``check`` now rejects is dropped and the model is asked as usual. Also keep each accepted
            ``check_<id>`` under its constraint and the elements it reads (:mod:`~.check_reuse`): a later subgoal
            monitoring the same constraint gets that function renumbered to its element ids, and the model is
            asked only for the other constraints (not at all when every one has a kept check).
        views: send the annotated views (the paper's coder sees them; default). False sends the request alone:
            the legend names every numbered element, so a coder that writes from the legend needs no image
            (saves one image per call: 85 estimated tokens for the default views).
    """

    def __init__(self, backend: VLMBackend, *, usage: UsageMeter | None = None,
                 prompt_version: str = PROMPT_VERSION, reuse: bool = True, views: bool = True) -> None:
        self.backend = backend
        self.views = views
        self.usage = usage if usage is not None else UsageMeter()
        self.prompt_version = prompt_version
        self.reuse = reuse
        self.reused = 0
        """Programs taken from the kept ones (no model call)."""
        self._kept: dict[str, str] = {}
        self._checks: dict[str, KeptCheck] = {}
        self.checks_reused = 0
        """Check functions taken from earlier programs into a new one (:mod:`~.check_reuse`)."""
        self.last_messages: list[Message] = []
        self.last_response: VLMResponse | None = None

    def build_messages(self, subgoal: Subgoal, elements: list[Element], annotated_images: dict[str, np.ndarray],
                       feedback: str | None = None) -> list[Message]:
        """System and user messages: the user message carries the ```json request block (:func:`coder_request`)
        and the annotated views without losing a pixel (:func:`view_parts`: stacked into one low-detail image when
        they fit in 512 x 512, else each at the cheapest lossless detail), so the labels stay as legible as drawn; none
        when ``views`` is off."""
        if not subgoal.constraints:
            raise ConfigError(f"subgoal {subgoal.text!r} has no constraints to monitor")
        request = coder_request(subgoal, elements, feedback)
        user = render("monitor_coder_user", self.prompt_version, request=dump_request(request))
        image = {"image": IMAGE_LINE if self.views else ""} if "image" in placeholders("monitor_coder",
                                                                                         self.prompt_version) else {}
        system = render("monitor_coder", self.prompt_version, **image)
        images = view_parts(annotated_images) if self.views else []
        return [Message.system(system), Message("user", [TextPart(user), *images])]

    def write_program(
        self,
        subgoal: Subgoal,
        elements: list[Element],
        annotated_images: dict[str, np.ndarray],
        check: ProgramCheck,
        max_retries: int = 2,
        feedback: str | None = None,
    ) -> str:
        """Program source accepted by ``check``.

        Args:
            check: raises ProgramError with the text to send back when it rejects a program.
            max_retries: re-asks after a rejected program.
            feedback: why a previous program of this subgoal was rejected (regeneration).
        A re-ask carries the original request, the last answer and its error; when the model answers a re-ask
        with the program it was just told about and that program is rejected with the same error, the next
        re-ask would be word for word the request just answered, so it is not sent (the model stands by a
        program that the current state rejects, e.g. a check that path coverage finds can never hold).

        Raises:
            VLMOutputError: nothing acceptable after ``1 + max_retries`` calls (or fewer, as above).
        """
        key = dump_request(coder_request(subgoal, elements)) if self.reuse and not feedback else None
        kept = self._kept.get(key) if key is not None else None
        try_checks = key is not None
        if kept is not None:
            try:
                check(kept)
            except ProgramError as exc:
                log.info("monitor coder: the kept program no longer passes (%s); asking the model", exc)
                del self._kept[key]
                try_checks = False  # its own functions, renumbered to the same ids, are that same program
            else:
                self.reused += 1
                return kept
        source = self._with_kept_checks(subgoal, elements, annotated_images, check, max_retries) \
            if try_checks else None
        if source is None:
            source = self._ask(subgoal, elements, annotated_images, check, max_retries, feedback)
        if key is not None:
            self._kept[key] = source
        if self.reuse:
            self._keep_checks(subgoal, elements, source)
        return source

    def _with_kept_checks(self, subgoal: Subgoal, elements: list[Element], annotated_images: dict[str, np.ndarray],
                          check: ProgramCheck, max_retries: int) -> str | None:
        """The program from the kept checks (:mod:`~code_as_monitor.planning.check_reuse`) of ``subgoal``'s
        constraints and, for the others, the model's answer to a request that asks only for them; the combined
        program must pass ``check``. None when no constraint has a kept check, or when the combined program is
        rejected (the caller then asks for the whole program)."""
        ids = resolve_element_ids(subgoal, elements)
        by_id = {e.id: e for e in elements}
        reused: dict[str, str] = {}
        for c in subgoal.constraints:
            kc = self._checks.get(check_key(c, ids[c.id], by_id))
            src = renumber(kc.source, kc.ids, ids[c.id]) if kc is not None else None
            if src is not None:
                reused[f"check_{c.id}"] = src
        if not reused:
            return None
        missing = [c for c in subgoal.constraints if f"check_{c.id}" not in reused]
        try:
            if not missing:
                source = combine(None, reused)
                check(source)
            else:
                asked = self._ask(replace(subgoal, constraints=missing), elements, annotated_images,
                                  lambda src: check(combine(src, reused)), max_retries, None)
                source = combine(asked, reused)
        except (ProgramError, VLMOutputError) as exc:
            log.info("monitor coder: the program with %d kept check(s) was rejected (%s); asking for all of it",
                     len(reused), exc)
            return None
        self.checks_reused += len(reused)
        return source

    def _keep_checks(self, subgoal: Subgoal, elements: list[Element], source: str) -> None:
        """Keep each ``check_<id>`` of an accepted program that can be renumbered exactly, under its key."""
        ids = resolve_element_ids(subgoal, elements)
        by_id = {e.id: e for e in elements}
        functions = split_checks(source)
        for c in subgoal.constraints:
            fn = functions.get(f"check_{c.id}")
            if fn is not None and renumber(fn, tuple(ids[c.id]), ids[c.id]) is not None:
                self._checks[check_key(c, ids[c.id], by_id)] = KeptCheck(fn, tuple(ids[c.id]))

    def _ask(self, subgoal: Subgoal, elements: list[Element], annotated_images: dict[str, np.ndarray],
             check: ProgramCheck, max_retries: int, feedback: str | None) -> str:
        """Ask the model for ``subgoal``'s program, re-asking with the error after a rejection (see
        :meth:`write_program`)."""
        messages = self.build_messages(subgoal, elements, annotated_images, feedback)
        last_error, last_answer, calls = "", None, 0
        request = messages
        for attempt in range(1 + max(0, max_retries)):
            calls = attempt + 1
            t0 = time.monotonic()
            resp = self.backend.complete(request, purpose=PURPOSE, schema=PROGRAM_SCHEMA)
            self.usage.record(PURPOSE, resp, time.monotonic() - t0)
            self.last_messages, self.last_response = request, resp
            source = program_text(resp.text)
            try:
                try:
                    ast.parse(source)
                except SyntaxError as exc:
                    raise ProgramError(f"syntax error at line {exc.lineno}: {exc.msg}") from None
                check(source)
            except ProgramError as exc:
                repeated = (resp.text, str(exc)) == (last_answer, last_error)
                last_error, last_answer = str(exc), resp.text
                log.info("monitor coder: program rejected (attempt %d): %s", attempt + 1, last_error)
                if repeated:
                    log.info("monitor coder: the same program and error again; not re-asking the same request")
                    break
                repair = render("repair", self.prompt_version, error=last_error, what="program")
                # the original request, the last answer and its error: not the growing conversation
                request = [*messages, Message.assistant(resp.text), Message.user(repair)]
                continue
            return source
        raise VLMOutputError(
            f"monitor coder: no acceptable program after {calls} attempt(s); last problem: "
            + last_error.replace("\n", " ")
        )
