"""A third corpus of hostile monitor programs, of kinds the first two do not cover: format-string walks,
reaching builtins through allowed objects, recursion through C code, allocations by broadcasting and
big integers, loops that feed themselves, and reaching threads, signals and file descriptors by name.

Same layout as ``hostile_attacks.py``: ``(name, source, kind, needle)`` with kind ``rejected``, ``fault``,
``frame``, ``either`` (``needle`` a regex), ``load`` or ``clean``. Every program defines a well-behaved
``check_b``.
"""

from __future__ import annotations

from hostile_attacks import _a, _top

KINDS: list[tuple[str, str, str, str]] = [
    # --- format strings: no way to walk attributes through a format spec or %-mapping -----------------
    ("percent_mapping_walk", _a("s = '%(__class__)s' % E\nreturn True, s"), "fault", "KeyError"),
    ("percent_mapping_dict_walk", _a("s = '%(x.__globals__)s' % {'x': distance}\nreturn True, s"), "fault",
     "KeyError"),
    ("format_builtin_walk", _a("return True, format(E, '{0.__class__}')"), "fault", "TypeError"),
    ("format_number_walk", _a("return True, format(1.5, '{0.__globals__}')"), "fault", "ValueError"),
    ("fstring_nested_spec_walk", _a("spec = '{0.__class__}'\nreturn True, f'{E[0]:{spec}}'"), "fault", "raised"),
    ("fstring_scalar_spec_walk", _a("spec = '{0.__init__.__globals__}'\nreturn True, f'{E[0][0, 0]:{spec}}'"),
     "fault", "ValueError"),
    ("percent_repr_of_helper", _a("return True, '%r' % (distance,)"), "clean", "0x?"),
    ("fstring_repr_of_bound_method", _a("return True, f'{E.get!r}'"), "clean", "0x?"),
    ("reason_unicode_line_breaks", _a("return True, 'one\\u2028two\\u2029three\\u202eowt\\u200bfour\\ufeff'"),
     "clean", "one two three owt four"),
    ("str_of_np_member", _a("return True, str(np.linalg.norm) + repr(np.linalg)"), "clean", "np.linalg"),
    # --- builtins and modules through allowed objects ---------------------------------------------------
    ("unbound_dict_method", _a("p = dict.get(E, 0)\nreturn True, 'x'"), "fault", "TypeError"),
    ("helper_given_functions", _a("d = distance(distance, len)\nreturn True, 'x'"), "fault", "raised"),
    ("abstract_numpy_type", _a("m = np.integer(3)\nreturn True, 'x'"), "fault", "TypeError"),
    ("max_key_builtin", _a("m = max([1, 2], key=isinstance)\nreturn True, 'x'"), "fault", "TypeError"),
    ("history_iteration", _a("n = 0\nfor i in H:\n    n += H[i].shape[0]\nreturn True, f'frames {n}'"), "clean",
     "frames 8"),
    ("os_by_name", _a("os.write(1, 'x')\nreturn True, 'x'"), "rejected", "'os'"),
    ("threading_by_name", _a("threading.Thread(target=len).start()\nreturn True, 'x'"), "rejected",
     "unknown name 'threading'"),
    ("signal_by_name", _a("signal.raise_signal(19)\nreturn True, 'x'"), "rejected", "unknown name 'signal'"),
    ("sys_modules", _a("m = sys.modules['os']\nreturn True, 'x'"), "rejected", "'sys'"),
    # --- recursion through C code ------------------------------------------------------------------------
    ("recursion_through_sorted_key", "def f(x):\n    return sorted([1, 2], key=f)\n\n\n"
     + _a("return f(0) is None, 'x'"), "fault", "RecursionError"),
    ("recursion_through_max_key", "def f(x):\n    return max([1, 2], key=f)\n\n\n" + _a("return f(0) > 0, 'x'"),
     "fault", "RecursionError"),
    ("recursion_through_fstring", "def f(n):\n    return f'{f(n + 1)}'\n\n\n" + _a("return True, f(0)"), "fault",
     "RecursionError"),
    ("deep_list_compare", _a("x = []\ny = []\nfor i in range(5000):\n    x = [x]\n    y = [y]\n"
                             "return x == y, 'x'"), "fault", "RecursionError"),
    ("deep_nested_np_array", _a("x = 1.0\nfor i in range(100):\n    x = [x]\na = np.array(x)\nreturn True, 'x'"),
     "fault", "ValueError"),
    # --- allocations -------------------------------------------------------------------------------------
    ("broadcast_huge", _a("a = np.ones(10 ** 5)[:, np.newaxis] * np.ones(10 ** 5)\nreturn True, 'x'"), "fault",
     "MemoryError"),
    ("eye_huge", _a("a = np.eye(10 ** 6)\nreturn True, 'x'"), "fault", "MemoryError"),
    ("bool_zeros_2gib", _a("a = np.zeros(2 ** 31, dtype=bool)\nreturn True, 'x'"), "fault", "MemoryError"),
    ("list_of_range_huge", _a("x = list(range(10 ** 9))\nreturn True, 'x'"), "either", "MemoryError|deadline"),
    ("big_int_power", _a("n = 2 ** (10 ** 10)\nreturn True, 'x'"), "either", "MemoryError|deadline"),
    ("tolist_huge", _a("x = np.ones((10 ** 4, 10 ** 4)).tolist()\nreturn True, 'x'"), "either",
     "MemoryError|deadline"),
    # --- loops --------------------------------------------------------------------------------------------
    ("self_feeding_list", _a("x = [0]\nfor v in x:\n    x.append(v)\nreturn True, 'x'"), "either",
     "MemoryError|deadline"),
    ("helper_calls_forever", _a("for i in range(10 ** 9):\n    d = distance(E[0], E[1])\nreturn True, 'x'"), "frame",
     "deadline"),
    ("generator_sum_forever", _a("return sum(i for i in range(10 ** 12)) > 0, 'x'"), "frame", "deadline"),
    ("load_time_generator", _top("X = sum(i * i for i in range(10 ** 12))"), "load", "did not finish"),
]
"""Other kinds of hostile programs (see the module docstring)."""
