"""A corpus of hostile or broken monitor programs for the constraints ``a`` (during) and ``b`` (upon).

Each entry is ``(name, source, expected, needle)``:
    expected: "rejected" (static validation raises ProgramError) or "fault" (runtime: ``check_a``
        gets a fault verdict; the loop keeps running);
    needle: a substring the rejection message or the fault reason must contain.
Every program defines a well-behaved ``check_b`` so the tests can see that other checks are unaffected.
"""

from __future__ import annotations

GOOD = '''
"""A well-behaved program: the block stays near the tip while carried; it ends up lifted."""

def check_a(E, H, t):
    d = distance(E[0], E[1])
    if d > 0.05:
        return False, f"block is {d:.3f} m from the tip", 0.05 - d
    return True, "block attached", 0.05 - d


def check_b(E, H, t):
    h = E[1][:, 2].mean()
    return bool(h > 0.1), f"block height {h:.2f} m"
'''


GOOD_B = '''
def check_b(E, H, t):
    return True, "fine", 1.0
'''


def _a(body: str) -> str:
    """A program whose check_a has the given (4-space indented) body."""
    lines = "\n".join("    " + line for line in body.strip("\n").splitlines())
    return f"def check_a(E, H, t):\n{lines}\n" + GOOD_B


CORPUS: list[tuple[str, str, str, str]] = [
    # --- escapes through dunders, reflection and string formatting -------------------------------------
    ("builtins_dunder", _a("f = __builtins__['eval']\nreturn True, 'x'"), "rejected", "'__builtins__'"),
    ("subclasses", _a("c = ().__class__.__bases__[0].__subclasses__()\nreturn True, str(len(c))"),
     "rejected", "'_'"),
    ("getattr", _a("f = getattr(np, 'load')\nreturn True, 'x'"), "rejected", "'getattr'"),
    ("str_format_escape", _a("s = '{0.__class__}'.format(E)\nreturn True, s"), "rejected", ".format"),
    ("format_map_escape", _a("s = '{x.__class__}'.format_map({'x': E})\nreturn True, s"), "rejected",
     ".format_map"),
    ("fstring_dunder", _a("return True, f'{E.__class__}'"), "rejected", "'_'"),
    ("fstring_huge_spec", _a("return True, f'{1.0:>1000000000}'"), "rejected", "format spec"),
    ("fstring_nested_width", _a("w = 10 ** 9\nreturn True, f'{1:>{w}}'"), "fault", "MemoryError"),
    ("percent_format_huge", _a("return True, '%*d' % (10 ** 9, 1)"), "rejected", "('*')"),
    ("percent_format_computed", _a("f = '%' + str(10 ** 9) + 'd'\nreturn True, f % 1"), "fault", "MemoryError"),
    ("np_load", _a("x = np.load('/etc/passwd')\nreturn True, 'x'"), "rejected", "np.load"),
    ("np_save", _a("np.save('/tmp/cam_pwned', E[0])\nreturn True, 'x'"), "rejected", "np.save"),
    ("np_ctypeslib", _a("p = np.ctypeslib.as_ctypes(E[0])\nreturn True, 'x'"), "rejected", "np.ctypeslib"),
    ("np_lib", _a("x = np.lib.format.open_memmap('/tmp/x')\nreturn True, 'x'"), "rejected", "np.lib"),
    ("array_tofile", _a("E[0].tofile('/tmp/cam_pwned')\nreturn True, 'x'"), "rejected", "'.tofile'"),
    ("import_ctypes", "import ctypes\n" + _a("return True, 'x'"), "rejected", "import"),
    ("import_in_function", _a("import os\nreturn True, 'x'"), "rejected", "import"),
    ("dunder_import", _a("os = __import__('os')\nreturn True, 'x'"), "rejected", "__import__"),
    ("exec_call", _a("exec('x = 1')\nreturn True, 'x'"), "rejected", "'exec'"),
    ("eval_call", _a("return eval('1 < 2'), 'x'"), "rejected", "'eval'"),
    ("open_call", _a("s = open('/etc/passwd').read()\nreturn True, s"), "rejected", "'open'"),
    ("globals_call", _a("g = globals()\nreturn True, 'x'"), "rejected", "'globals'"),
    ("locals_vars", _a("a = locals()\nb = vars()\nreturn True, 'x'"), "rejected", "'locals'"),
    ("compile_call", _a("c = compile('1', 's', 'eval')\nreturn True, 'x'"), "rejected", "'compile'"),
    ("type_call", _a("k = type(E)\nreturn True, 'x'"), "rejected", "'type'"),
    ("unknown_module", _a("os.system('true')\nreturn True, 'x'"), "rejected", "'os'"),
    ("lambda_trick", _a("f = lambda: 1\nreturn True, 'x'"), "rejected", "lambda"),
    ("call_a_variable", _a("f = distance\nreturn f(E[0], E[1]) > 0, 'x'"), "rejected", "calling 'f'"),
    # --- forbidden statements ---------------------------------------------------------------------
    ("while_true", _a("while True:\n    pass\nreturn True, 'x'"), "rejected", "'while'"),
    ("class_def", "class A:\n    pass\n" + _a("return True, 'x'"), "rejected", "class"),
    ("try_swallow", _a("try:\n    x = 1 / 0\nexcept Exception:\n    pass\nreturn True, 'x'"), "rejected", "'try'"),
    ("global_stmt", _a("global X\nX = 1\nreturn True, 'x'"), "rejected", "'global'"),
    ("nonlocal_stmt", _a("x = 0\ndef g():\n    nonlocal x\n    x = 1\ng()\nreturn True, 'x'"), "rejected",
     "'nonlocal'"),
    ("walrus", _a("if (d := distance(E[0], E[1])) > 0.1:\n    return False, 'far'\nreturn True, 'x'"),
     "rejected", ":="),
    ("generator_yield", _a("yield True, 'x'"), "rejected", "yield"),
    ("raise_stmt", _a("raise ValueError('no')"), "rejected", "'raise'"),
    ("with_stmt", _a("with open('/etc/passwd') as f:\n    pass\nreturn True, 'x'"), "rejected", "'with'"),
    ("decorator", "@staticmethod\n" + _a("return True, 'x'"), "rejected", "decorator"),
    ("h_attribute", _a("d = H.items()\nreturn True, 'x'"), "rejected", "H has no attribute"),
    ("mutate_E", _a("E[0] = np.zeros((1, 3))\nreturn True, 'x'"), "rejected", "must not modify"),
    ("assign_attribute", _a("H.t = None\nreturn True, 'x'"), "rejected", "attribute"),
    ("huge_int_literal", _a("n = 100000000000\nreturn True, 'x'"), "rejected", "integer literal"),
    ("huge_str_literal", _a("s = '" + "a" * 3000 + "'\nreturn True, s"), "rejected", "string literal"),
    ("top_level_code", "x = [1]\nfor i in range(3):\n    pass\n" + _a("return True, 'x'"), "rejected",
     "top level"),
    ("shadow_helper", _a("distance = distance(E[0], E[1])\nreturn distance < 0.1, 'x'"), "rejected",
     "shadows"),
    # --- broken structure ---------------------------------------------------------------------------
    ("syntax_error", "def check_a(E, H, t)\n    return True, 'x'\n" + GOOD_B, "rejected", "syntax error"),
    ("missing_check", GOOD_B, "rejected", "missing check function: def check_a"),
    ("wrong_signature", "def check_a(E, H):\n    return True, 'x'\n" + GOOD_B, "rejected", "signature (E, H, t)"),
    ("extra_check", _a("return True, 'x'") + "\ndef check_c(E, H, t):\n    return True, 'x'\n", "rejected",
     "extra check function 'check_c'"),
    # --- contained at run time ---------------------------------------------------------------------
    ("for_huge_range", _a("for i in range(10 ** 12):\n    pass\nreturn True, 'x'"), "fault", "deadline"),
    ("nested_loops", _a("s = 0\nfor i in range(10 ** 5):\n    for j in range(10 ** 5):\n        s += 1\n"
                        "return True, 'x'"), "fault", "deadline"),
    ("sum_huge_range", _a("return sum(range(10 ** 10)) > 0, 'x'"), "fault", "deadline"),
    ("deep_recursion", "def f(n):\n    return f(n + 1)\n" + _a("return f(0) > 0, 'x'"), "fault", "RecursionError"),
    ("np_ones_huge", _a("x = np.ones(10 ** 10)\nreturn True, 'x'"), "fault", "MemoryError"),
    ("np_zeros_square", _a("x = np.zeros((10 ** 5, 10 ** 5))\nreturn True, 'x'"), "fault", "MemoryError"),
    ("huge_string", _a("s = 'a' * 10 ** 10\nreturn True, s"), "fault", "MemoryError"),
    ("huge_list", _a("x = [0] * 10 ** 9\nreturn True, 'x'"), "fault", "MemoryError"),
    ("return_none", _a("return None"), "fault", "returned NoneType"),
    ("fall_off_end", _a("x = 1"), "fault", "returned NoneType"),
    ("return_int", _a("return 1"), "fault", "returned int"),
    ("return_short_tuple", _a("return (True,)"), "fault", "length 1"),
    ("return_long_tuple", _a("return True, 'x', 1.0, 2"), "fault", "length 4"),
    ("ok_is_str", _a("return 'yes', 'x'"), "fault", "ok must be a bool"),
    ("ok_is_int", _a("return 1, 'x'"), "fault", "ok must be a bool"),
    ("reason_not_str", _a("return True, 5"), "fault", "reason must be a str"),
    ("nan_margin", _a("return True, 'x', float('nan')"), "fault", "margin is not finite"),
    ("margin_not_number", _a("return True, 'x', 'big'"), "fault", "margin must be a float"),
    ("return_array", _a("return np.array([True])"), "fault", "returned ndarray"),
    ("ok_is_array", _a("return np.array([True, False]), 'x'"), "fault", "ok must be a bool"),
    ("zero_division", _a("return 1 / 0 > 0, 'x'"), "fault", "ZeroDivisionError"),
    ("missing_element", _a("return distance(E[99], E[0]) > 0, 'x'"), "fault", "KeyError"),
    ("singular_matrix", _a("m = np.linalg.inv(np.zeros((3, 3)))\nreturn True, 'x'"), "fault", "LinAlgError"),
    ("mutate_alias", _a("p = E[0]\np[0, 0] = 5.0\nreturn True, 'x'"), "fault", "read-only"),
    ("mutate_mapping_alias", _a("d = E\nd[0] = 1\nreturn True, 'x'"), "fault", "TypeError"),
    ("missing_history", _a("return displacement(H[42]) > 0, 'x'"), "fault", "KeyError"),
]
