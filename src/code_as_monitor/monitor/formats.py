"""The static bound on the formats a monitor program writes (a layer-1 check of :mod:`.validate`).

A format's width or precision sizes the string it builds: ``'%.100000000f' % x`` or ``f'{x:>1000000000}'`` asks
for hundreds of megabytes in one expression. Widths and precisions written in the program (an f-string's spec, a
literal ``format(x, spec)`` spec, a printf-style string before ``%``) are at most :data:`MAX_FORMAT_NUMBER`, and a
printf ``*`` (the width taken from the arguments) is refused; one computed at run time is bounded by the worker's
memory limit and the frame deadline.
"""

from __future__ import annotations

import ast
import re

MAX_FORMAT_NUMBER = 64
"""The largest number a written format spec may hold (a width, a precision)."""

_NUMBER_RE = re.compile(r"\d+")
_PERCENT_SPEC_RE = re.compile(r"%(?:\([^)]*\))?[#0 +-]*(\*|\d+)?(?:\.(\*|\d*))?[hlL]?(.)", re.DOTALL)
"""One ``%`` conversion of a printf-style format string: (width, precision, conversion type)."""


def format_spec_error(spec: str) -> str:
    """Why an f-string's or ``format()``'s spec is refused (a number in it over :data:`MAX_FORMAT_NUMBER`); ""
    when it is fine."""
    if any(int(n) > MAX_FORMAT_NUMBER for n in _NUMBER_RE.findall(spec)):
        return f"format spec {spec!r} is too wide (numbers <= {MAX_FORMAT_NUMBER})"
    return ""


def percent_format_errors(text: str) -> list[str]:
    """Why the printf-style format string ``text`` is refused: a width or precision over :data:`MAX_FORMAT_NUMBER`
    or taken from the arguments (``'%*d'``); [] when it is fine."""
    errors = []
    for m in _PERCENT_SPEC_RE.finditer(text):
        width, precision, conv = m.group(1), m.group(2), m.group(3)
        if conv == "%":
            continue
        if "*" in (width, precision):
            errors.append(f"format string {text!r}: a width or precision from the arguments ('*') is not allowed")
        elif any(n and int(n) > MAX_FORMAT_NUMBER for n in (width, precision)):
            errors.append(f"format string {text!r} is too wide (widths and precisions <= {MAX_FORMAT_NUMBER})")
    return errors


def format_errors(node: ast.AST) -> list[str]:
    """Why the format ``node`` writes is refused: a printf-style string literal before ``%``, an f-string's spec (its
    literal parts), or ``format(x, 'spec')`` with a literal spec; [] for any other node or a fine format."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mod) and isinstance(node.left, ast.Constant) \
            and isinstance(node.left.value, str):
        return percent_format_errors(node.left.value)
    if isinstance(node, ast.FormattedValue) and node.format_spec is not None:
        texts = [p.value for p in ast.walk(node.format_spec)
                 if isinstance(p, ast.Constant) and isinstance(p.value, str)]
        return [why for why in map(format_spec_error, texts) if why]
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "format" \
            and len(node.args) > 1 and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str):
        why = format_spec_error(node.args[1].value)
        return [why] if why else []
    return []


__all__ = ["MAX_FORMAT_NUMBER", "format_errors", "format_spec_error", "percent_format_errors"]
