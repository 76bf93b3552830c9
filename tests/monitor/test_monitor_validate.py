"""Static validation: what a realistic program may use, and how rejections read."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
import textwrap

import pytest
from hostile_programs import GOOD

from code_as_monitor.core.constraints import Constraint
from code_as_monitor.core.errors import ProgramError
from code_as_monitor.monitor.validate import MAX_NODES, validate_program

RICH = '''
"""Uses most of what is allowed."""
TOL = 0.02
ANGLE = math.radians(15)


def _lifted(points, margin: float = 0.01) -> bool:
    return float(points[:, 2].min()) > margin


def check_a(E: dict, H, t: float) -> tuple[bool, str, float]:
    n = normal(E[1])
    tilt = angle_between(n, np.array([0.0, 0.0, 1.0]))
    speeds = [np.linalg.norm(H[1][i + 1].mean(axis=0) - H[1][i].mean(axis=0)) for i in range(len(H.t) - 1)]
    fast = max(speeds) if speeds else 0.0
    moved = displacement(H[1]) if H.t.shape[0] > 1 else 0.0
    label = "tilted" if tilt > ANGLE else "level"
    for i, p in enumerate(E[1].tolist()):
        if p[2] < -TOL:
            return False, f"corner {i} below the table ({p[2]:.3f} m)", p[2] + TOL
        elif abs(p[0]) > 1.0 or not -1.0 < p[1] < 1.0:
            continue
    ok = tilt <= ANGLE and _lifted(E[1])
    x: float = -1.0
    why = f"{label}: tilt {math.degrees(tilt):.1f} deg, moved {moved:.3f}, v {fast:.2f}, t={t}"
    return ok, why, ANGLE - tilt + x + 1


def check_b(E, H, t):
    inside = count_in_polygon([E[0]], E[1])
    pts = {i: centroid(E[i]) for i in E.keys()}
    return inside >= 0 and len(pts) == 2, "ok"
'''


def test_good_programs_pass(constraints):
    for src in (GOOD, RICH):
        tree = validate_program(src, constraints)
        assert isinstance(tree, ast.Module)
        compile(tree, "<test>", "exec")  # compiles; never executed here


def test_annotations_are_stripped_and_never_evaluated(constraints):
    src = RICH.replace("def check_b(E, H, t):", "def check_b(E, H, t) -> __import__('os').system('x'):")
    tree = validate_program(src, constraints)
    assert "__import__" not in ast.unparse(tree)
    assert all(f.returns is None for f in ast.walk(tree) if isinstance(f, ast.FunctionDef))


def test_message_lists_every_problem_with_its_line(constraints):
    src = GOOD + "\n\ndef helper(x):\n    import os\n    while x:\n        x = eval('0')\n    return x.__class__\n"
    with pytest.raises(ProgramError) as err:
        validate_program(src, constraints)
    msg = str(err.value)
    n = src[: src.index("import os")].count("\n") + 1
    for needle in (f"line {n}: import", f"line {n + 1}: 'while'", f"line {n + 2}: the name 'eval'",
                   f"line {n + 3}: attribute names"):
        assert needle in msg, msg


def test_attribute_allow_lists(constraints):
    def body(expr: str) -> str:
        return GOOD.replace('h = E[1][:, 2].mean()', f"h = {expr}")

    validate_program(body("np.linalg.norm(E[1]) + math.hypot(1, 2) + np.pi + E[1].T.shape[0]"), constraints)
    for expr, needle in [("np.linalg.lstsq2(E[1])", "np.linalg.lstsq2"), ("np.fromfile('x')", "np.fromfile"),
                         ("np.memmap('x')", "np.memmap"), ("math.factorial(10)", "math.factorial"),
                         ("E[1].view()", "'.view'"), ("E[1].dtype", "'.dtype'"), ("H.t._d", "'_'"),
                         ("E[1][0].setflags(write=True)", "'.setflags'")]:
        with pytest.raises(ProgramError, match="not allowed") as err:
            validate_program(body(expr), constraints)
        assert needle in str(err.value)


def test_check_functions_must_match_constraints():
    cs = [Constraint("x_1", "t", "during")]
    validate_program("def check_x_1(E, H, t):\n    return True, 'ok'\n", cs)
    with pytest.raises(ProgramError, match="defined twice"):
        validate_program("def check_x_1(E, H, t):\n    return True, 'a'\n" * 2, cs)
    with pytest.raises(ProgramError, match=r"signature \(E, H, t\)"):
        validate_program("def check_x_1(E, H, t, extra=1):\n    return True, 'ok'\n", cs)
    with pytest.raises(ProgramError, match=r"signature \(E, H, t\)"):
        validate_program("def check_x_1(*args):\n    return True, 'ok'\n", cs)


def test_size_limits(constraints):
    with pytest.raises(ProgramError, match="too long"):
        validate_program("#" * 60_000, constraints)
    big = GOOD + "\n".join(f"X{i} = [{', '.join(['1'] * 20)}]" for i in range(MAX_NODES // 20))
    with pytest.raises(ProgramError, match="too large"):
        validate_program(big, constraints)
    with pytest.raises(ProgramError):
        validate_program(GOOD + "Y = " + "(" * 500 + "1" + ")" * 500 + "\n", constraints)


PARSE_BOMBS = {
    "unary_minus": "-" * 45_000 + "1",
    "not_chain": "not " * 11_000 + "t",
    "add_chain": "1+" * 22_000 + "1",
    "attribute_chain": "t" + ".real" * 9_000,
    "subscript_chain": "t" + "[0]" * 15_000,
    "call_chain": "abs" + "(1)" * 15_000,
    "and_chain": "t and " * 8_000 + "t",
    "compare_chain": "t < " * 11_000 + "t",
    "conditional_chain": "1 if t else " * 4_000 + "1",
    "power_chain": "2**" * 16_000 + "2",
    "nested_lambdas": "(lambda: " * 3_000 + "1" + ")" * 3_000,
    "nested_lists": "[" * 180 + "]" * 180,
}
"""Expressions (under the 50 000-character limit) built to exhaust the parser's or the checker's stack."""


def test_parse_bombs_are_rejected_by_the_host_without_crashing():
    """The control process parses untrusted text: every bomb is a ProgramError, never a crash (run in a
    child process so that a crash would show as its exit status instead of taking pytest down)."""
    script = textwrap.dedent("""
        import json, sys
        from code_as_monitor.core.constraints import Constraint, Phase
        from code_as_monitor.core.errors import ProgramError
        from code_as_monitor.monitor.validate import validate_program
        out = {}
        for name, expr in json.loads(sys.stdin.read()).items():
            src = "def check_a(E, H, t):\\n    return True, 'x', " + expr + "\\n"
            try:
                validate_program(src, [Constraint("a", "x", Phase.DURING)])
                out[name] = "accepted"
            except ProgramError as exc:
                out[name] = "rejected: " + str(exc)
        print(json.dumps(out))
    """)
    done = subprocess.run([sys.executable, "-c", script], input=json.dumps(PARSE_BOMBS), capture_output=True,
                          text=True, timeout=240)
    assert done.returncode == 0, done.stderr[-2000:]
    results = json.loads(done.stdout)
    assert set(results) == set(PARSE_BOMBS)
    for name, outcome in results.items():
        assert outcome.startswith("rejected: monitor program rejected"), (name, outcome[:200])


def test_non_string_source(constraints):
    with pytest.raises(ProgramError, match="must be a str"):
        validate_program(b"def check_a(E, H, t): pass", constraints)  # type: ignore[arg-type]
