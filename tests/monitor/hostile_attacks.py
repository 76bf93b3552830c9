"""A second corpus of hostile monitor programs (constraints ``a`` during, ``b`` upon), by attack class.

Written against the public validator and sandbox as an attacker would, after the first corpus
(``hostile_programs.py``) was passing. Each entry is ``(name, source, kind, needle)``:

    rejected  static validation raises ProgramError whose message contains ``needle``;
    fault     check_a gets a fault verdict whose reason contains ``needle``; check_b is unaffected;
    frame     the whole frame is a fault (deadline, worker killed or crashed): ``needle`` in the reasons;
    either    check_a is a fault whose reason matches the regex ``needle`` (say a memory error, or the
              deadline when the allocations are slow on a loaded machine; the whole frame then);
    load      loading raises ProgramError containing ``needle`` (module-level code);
    clean     check_a returns a verdict (no fault) that the host has sanitised: at most 300 characters,
              no control characters, no object addresses; ``needle`` is in the reason.

Every program defines a well-behaved ``check_b``.
"""

from __future__ import annotations

GOOD_B = '''

def check_b(E, H, t):
    return True, "fine", 1.0
'''

CANARY = "/tmp/cam_hostile_canary"
"""A path hostile programs try to create; the tests check it never exists."""


def _a(body: str) -> str:
    lines = "\n".join("    " + line for line in body.strip("\n").splitlines())
    return f"def check_a(E, H, t):\n{lines}\n" + GOOD_B


def _top(module_level: str) -> str:
    return module_level.strip("\n") + "\n\n" + _a("return True, 'x'")


REFLECTION: list[tuple[str, str, str, str]] = [
    ("mro_walk", _a("k = E.__class__.__mro__[-1]\nreturn True, str(k)"), "rejected", "'_'"),
    ("globals_of_helper", _a("g = distance.__globals__\nreturn True, str(len(g))"), "rejected", "'_'"),
    ("code_of_check", _a("c = check_a.__code__\nreturn True, 'x'"), "rejected", "'_'"),
    ("np_dict", _a("d = np.__dict__\nreturn True, 'x'"), "rejected", "'_'"),
    ("math_loader", _a("m = math.__loader__\nreturn True, 'x'"), "rejected", "'_'"),
    ("history_internals", _a("d = H._d\nreturn True, 'x'"), "rejected", "'_'"),
    ("bound_self", _a("d = E.get.__self__\nreturn True, 'x'"), "rejected", "'_'"),
    ("type_mro", _a("k = type(E).mro()\nreturn True, 'x'"), "rejected", "'type'"),
    ("object_subclasses", _a("s = object.__subclasses__()\nreturn True, 'x'"), "rejected", "'object'"),
    ("super_call", _a("s = super()\nreturn True, 'x'"), "rejected", "'super'"),
    ("vars_np", _a("v = vars(np)\nreturn True, 'x'"), "rejected", "'vars'"),
    ("dir_probe", _a("names = dir(E)\nreturn True, 'x'"), "rejected", "'dir'"),
    ("hasattr_probe", _a("h = hasattr(E, 'x')\nreturn True, 'x'"), "rejected", "'hasattr'"),
    ("id_leak", _a("return True, str(id(E))"), "rejected", "'id'"),
    ("breakpoint_call", _a("breakpoint()\nreturn True, 'x'"), "rejected", "'breakpoint'"),
    ("help_call", _a("help(np)\nreturn True, 'x'"), "rejected", "'help'"),
    ("iter_next", _a("it = iter([1])\nx = next(it)\nreturn True, 'x'"), "rejected", "'iter'"),
    ("memoryview_raw", _a("m = memoryview(E[0])\nreturn True, 'x'"), "rejected", "'memoryview'"),
    ("bytearray_buf", _a("b = bytearray(64)\nreturn True, 'x'"), "rejected", "'bytearray'"),
    ("bytes_literal", _a("b = b'\\x00' * 8\nreturn True, 'x'"), "rejected", "bytes literals"),
    ("format_spec_attr", _a("s = '{0.__class__.__mro__}'.format(E)\nreturn True, s"), "rejected", ".format"),
    ("percent_dunder", _a("s = '%s' % (E.__class__,)\nreturn True, s"), "rejected", "'_'"),
    ("dunder_name_binding", _a("__x = 1\nreturn True, 'x'"), "rejected", "'__x'"),
    ("dunder_loop_var", _a("for __i in range(2):\n    pass\nreturn True, 'x'"), "rejected", "'__i'"),
    ("builtins_name", _a("b = builtins\nreturn True, 'x'"), "rejected", "'builtins'"),
    ("spec_name", _a("s = __spec__\nreturn True, 'x'"), "rejected", "'__spec__'"),
    ("importlib_name", _a("m = importlib.import_module('os')\nreturn True, 'x'"), "rejected", "'importlib'"),
    ("from_import", "from os import system\n" + _a("return True, 'x'"), "rejected", "import"),
    ("linalg_internal", _a("m = np.linalg.linalg\nreturn True, 'x'"), "rejected", "np.linalg.linalg"),
    ("np_math_module", _a("m = np.math\nreturn True, 'x'"), "rejected", "np.math"),
    ("exit_call", _a("exit(0)"), "rejected", "'exit'"),
    ("quit_call", _a("quit()"), "rejected", "'quit'"),
    ("shadow_np", _a("np = 1\nreturn True, 'x'"), "rejected", "shadows"),
    ("shadow_builtin", _a("len = 3\nreturn True, 'x'"), "rejected", "shadows"),
    ("call_through_dict", _a("fs = {'f': distance}\nreturn fs['f'](E[0], E[1]) > 0, 'x'"), "rejected",
     "must name its function directly"),
    ("call_returned_function", "def g():\n    return distance\n" + _a("return g()(E[0], E[1]) > 0, 'x'"),
     "rejected", "must name its function directly"),
    ("call_parameter", "def g(f, a, b):\n    return f(a, b)\n" + _a("return g(distance, E[0], E[1]) > 0, 'x'"),
     "rejected", "calling 'f'"),
    ("getattr_as_key", _a("s = sorted([E], key=getattr)\nreturn True, 'x'"), "rejected", "'getattr'"),
    ("async_def", "async def g():\n    return 1\n" + _a("return True, 'x'"), "rejected", "async def"),
    ("try_star", _a("try:\n    pass\nexcept* ValueError:\n    pass\nreturn True, 'x'"), "rejected", "'try'"),
    ("match_stmt", _a("match t:\n    case 1:\n        pass\nreturn True, 'x'"), "rejected", "'match'"),
    ("lambda_default", "def g(f=lambda: 1):\n    return 1\n" + _a("return True, 'x'"), "rejected", "lambda"),
    ("generator_expression_escape", _a("g = (x for x in [1])\nf = g.gi_frame\nreturn True, 'x'"), "rejected",
     "'.gi_frame'"),
]
"""Reflection, dunders, forbidden builtins and call tricks: all stopped by the static allow-list."""

NUMPY_MEMORY: list[tuple[str, str, str, str]] = [
    ("ndarray_over_buffer", _a("a = np.ndarray((100,), buffer=E[0], offset=0, strides=(8,))\nreturn True, 'x'"),
     "rejected", "np.ndarray(...) cannot be called"),
    ("ndarray_zero_strides", _a("a = np.ndarray(shape=(10**6,), dtype=np.float64, buffer=H.t, strides=(0,))\n"
                                "return True, 'x'"), "rejected", "np.ndarray(...) cannot be called"),
    ("frombuffer", _a("a = np.frombuffer(E[0], dtype=np.int64)\nreturn True, 'x'"), "rejected", "np.frombuffer"),
    ("as_strided", _a("a = np.lib.stride_tricks.as_strided(E[0], shape=(10**6,), strides=(0,))\nreturn True, 'x'"),
     "rejected", "np.lib"),
    ("ctypeslib", _a("a = np.ctypeslib.as_array(E[0])\nreturn True, 'x'"), "rejected", "np.ctypeslib"),
    ("array_ctypes", _a("p = E[0].ctypes.data\nreturn True, str(p)"), "rejected", "'.ctypes'"),
    ("array_data", _a("b = E[0].data\nreturn True, 'x'"), "rejected", "'.data'"),
    ("array_view", _a("a = E[0].view(np.int64)\nreturn True, 'x'"), "rejected", "'.view'"),
    ("array_interface", _a("d = E[0].__array_interface__\nreturn True, str(d)"), "rejected", "'_'"),
    ("array_strides", _a("s = E[0].strides\nreturn True, str(s)"), "rejected", "'.strides'"),
    ("array_base", _a("b = E[0].base\nreturn True, 'x'"), "rejected", "'.base'"),
    ("array_flags", _a("f = E[0].flags\nreturn True, 'x'"), "rejected", "'.flags'"),
    ("object_dtype_name", _a("a = np.array([1], dtype=object)\nreturn True, 'x'"), "rejected", "'object'"),
    ("object_dtype_code", _a("a = np.array([1], dtype='O')\nreturn True, 'x'"), "rejected", "dtype"),
    ("object_dtype_dict", _a("a = np.array([1], dtype=dict)\nreturn True, 'x'"), "rejected", "dtype"),
    ("astype_object", _a("a = E[0].astype('O')\nreturn True, 'x'"), "rejected", "'.astype(...)' needs one dtype"),
    ("astype_dynamic", _a("k = 'O'\na = E[0].astype(k)\nreturn True, 'x'"), "rejected", "'.astype(...)' needs"),
    ("void_dtype", _a("a = np.zeros(3, dtype='V8')\nreturn True, 'x'"), "rejected", "dtype"),
    ("bytes_dtype", _a("a = np.array(['ab'], dtype='S2')\nreturn True, 'x'"), "rejected", "dtype"),
    ("datetime_dtype", _a("a = np.arange(3, dtype='m8')\nreturn True, 'x'"), "rejected", "dtype"),
    ("reduction_positional_dtype", _a("s = E[1].sum(0, 'O')\nreturn True, 'x'"), "rejected", "positional"),
    ("out_keyword", _a("np.clip(E[0], 0, 1, out=E[0])\nreturn True, 'x'"), "rejected", "'out='"),
    ("memmap", _a("m = np.memmap('/etc/passwd')\nreturn True, 'x'"), "rejected", "np.memmap"),
    ("np_fromfile", _a("a = np.fromfile('/etc/passwd', dtype=np.uint8)\nreturn True, 'x'"), "rejected",
     "np.fromfile"),
    ("np_loadtxt", _a("a = np.loadtxt('/etc/hostname')\nreturn True, 'x'"), "rejected", "np.loadtxt"),
    ("np_savetxt", _a(f"np.savetxt('{CANARY}', E[0])\nreturn True, 'x'"), "rejected", "np.savetxt"),
    ("frompyfunc", _a("f = np.frompyfunc(distance, 2, 1)\nreturn True, 'x'"), "rejected", "np.frompyfunc"),
    ("vectorize", _a("f = np.vectorize(distance)\nreturn True, 'x'"), "rejected", "np.vectorize"),
    ("f2py", _a("m = np.f2py\nreturn True, 'x'"), "rejected", "np.f2py"),
    ("np_testing", _a("m = np.testing\nreturn True, 'x'"), "rejected", "np.testing"),
    ("set_printoptions", _a("np.set_printoptions(threshold=10**9)\nreturn True, 'x'"), "rejected",
     "np.set_printoptions"),
    ("seterr_global", _a("np.seterr(all='raise')\nreturn True, 'x'"), "rejected", "np.seterr"),
    ("np_dtype_ctor", _a("d = np.dtype('O')\nreturn True, 'x'"), "rejected", "np.dtype"),
    ("np_object_type", _a("a = np.object_(1)\nreturn True, 'x'"), "rejected", "np.object_"),
    ("np_void_type", _a("a = np.void(8)\nreturn True, 'x'"), "rejected", "np.void"),
    ("np_rec", _a("r = np.rec.array([(1, 2)])\nreturn True, 'x'"), "rejected", "np.rec"),
    ("from_dlpack", _a("a = np.from_dlpack(E[0])\nreturn True, 'x'"), "rejected", "np.from_dlpack"),
    ("setflags_write", _a("E[0].setflags(write=True)\nreturn True, 'x'"), "rejected", "'.setflags'"),
    ("itemset", _a("E[0].itemset(0, 1.0)\nreturn True, 'x'"), "rejected", "'.itemset'"),
    ("tobytes", _a("b = E[0].tobytes()\nreturn True, 'x'"), "rejected", "'.tobytes'"),
    # accepted statically, refused at run time by the np proxy
    ("positional_object_dtype", _a("a = np.zeros(3, 'O')\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("full_of_functions", _a("a = np.full(3, distance)\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("array_of_objects", _a("a = np.array([distance, E])\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("array_of_mapping", _a("a = np.array(E)\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("where_objects", _a("a = np.where(True, distance, distance)\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("tile_objects", _a("a = np.tile([distance], 3)\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("sum_positional_object", _a("a = np.sum(np.ones((2, 2)), 0, 'O')\nreturn True, 'x'"), "fault", "dtype '|O'"),
    ("linalg_of_functions", _a("n = np.linalg.norm([distance])\nreturn True, 'x'"), "fault", "raised"),
    ("operator_object_array", _a("a = E[0] + [distance]\nreturn True, 'x'"), "fault", "TypeError"),
    ("positional_out_read_only", _a("np.clip(E[0], 0, 1, E[0])\nreturn True, 'x'"), "fault", "read-only"),
    ("maximum_into_input", _a("np.maximum(E[1], 0, E[1])\nreturn True, 'x'"), "fault", "read-only"),
    ("call_ndarray_alias", _a("k = np.ndarray\nreturn isinstance(E[0], k), 'x'"), "clean", "x"),
]
"""numpy as a raw-memory primitive: stopped statically, or by the np proxy at run time (a fault)."""

DENIAL: list[tuple[str, str, str, str]] = [
    ("loop_billion", _a("n = 0\nfor i in range(10 ** 9):\n    n += 1\nreturn True, 'x'"), "frame", "deadline"),
    ("max_huge_range", _a("return max(range(10 ** 11)) > 0, 'x'"), "frame", "deadline"),
    ("sorted_huge", _a("s = sorted(range(10 ** 9), reverse=True)\nreturn True, 'x'"), "either",
     "MemoryError|deadline"),
    # past the worker's memory limit first (a MemoryError faults its own check) or past the deadline (the frame)
    ("svd_huge", _a("u = np.linalg.svd(np.ones((3000, 3000)))\nreturn True, 'x'"), "either", "MemoryError|deadline"),
    ("many_allocations", _a("for i in range(10 ** 6):\n    z = np.zeros(10 ** 5)\nreturn True, 'x'"), "frame",
     "deadline"),
    ("string_doubling", _a("s = 'ab'\nfor i in range(64):\n    s = s + s\nreturn True, 'x'"), "either",
     "MemoryError|deadline"),
    ("list_doubling", _a("x = [0.5]\nfor i in range(64):\n    x = x + x\nreturn True, 'x'"), "either",
     "MemoryError|deadline"),
    ("arange_huge", _a("a = np.arange(10 ** 10)\nreturn True, 'x'"), "fault", "MemoryError"),
    ("linspace_huge", _a("a = np.linspace(0, 1, 10 ** 10)\nreturn True, 'x'"), "fault", "MemoryError"),
    ("outer_huge", _a("a = np.outer(np.ones(10 ** 5), np.ones(10 ** 5))\nreturn True, 'x'"), "fault",
     "MemoryError"),
    ("repeat_huge", _a("a = np.repeat(E[1], 10 ** 9, axis=0)\nreturn True, 'x'"), "fault", "MemoryError"),
    ("tile_huge", _a("a = np.tile(E[1], (10 ** 5, 10 ** 4))\nreturn True, 'x'"), "fault", "MemoryError"),
    ("list_of_arrays_huge", _a("x = [E[0]] * 10 ** 9\nreturn True, 'x'"), "fault", "MemoryError"),
    ("percentile_huge", _a("p = np.percentile(np.zeros(10 ** 9), 50)\nreturn True, 'x'"), "fault", "MemoryError"),
    # a literal spec or printf-style format string is bounded statically, as an f-string's is ...
    ("format_builtin_width", _a("s = format(1.5, '>999999999')\nreturn True, s"), "rejected", "too wide"),
    ("percent_precision", _a("s = '%.*f' % (10 ** 8, 1.5)\nreturn True, s"), "rejected", "('*')"),
    ("percent_literal_precision", _a("s = '%.100000000f' % 1.5\nreturn True, s"), "rejected", "too wide"),
    ("percent_literal_width", _a("s = 'off %100000000d mm' % 3\nreturn True, s"), "rejected", "too wide"),
    ("percent_named_width", _a("s = '%(d)999999999.3f' % {'d': 1.5}\nreturn True, s"), "rejected", "too wide"),
    # ... a computed one is not: raised, late, or made in time and cut to the reason's length
    ("format_builtin_computed_width", _a("w = '>' + str(10 ** 9)\ns = format(1.5, w)\nreturn True, s"), "fault",
     "raised"),
    ("percent_computed_precision", _a("f = '%.' + str(10 ** 8) + 'f'\ns = f % 1.5\nreturn True, s"), "bounded",
     "raised|deadline"),
    ("fstring_in_fstring_width", _a("s = f\"{f'{1:>{10 ** 8}}'}\"\nreturn True, s"), "bounded",
     "raised|deadline"),
    ("shift_huge", _a("n = 1 << (10 ** 10)\nreturn True, 'x'"), "either", "MemoryError|deadline"),
    ("join_huge", _a("s = ','.join(['x' * 10 ** 4] * 10 ** 5)\nreturn True, s"), "either", "MemoryError|deadline"),
    ("fstring_expression_width", _a("w = 10 ** 9\ns = f'{1.5:>{w}}'\nreturn True, s"), "fault", "MemoryError"),
    ("int_to_str_limit", _a("n = 7 ** 100000\nreturn True, str(n)"), "fault", "ValueError"),
    ("mutual_recursion", "def f(n):\n    return g(n + 1)\n\n\ndef g(n):\n    return f(n + 1)\n"
     + _a("return f(0) > 0, 'x'"), "fault", "RecursionError"),
    ("recursion_in_comprehension", "def f(n):\n    return [f(n + 1) for _ in range(1)]\n"
     + _a("x = f(0)\nreturn True, 'x'"), "fault", "RecursionError"),
    ("nested_repr", _a("x = []\nfor i in range(10 ** 5):\n    x = [x]\nreturn True, str(x)"), "fault",
     "RecursionError"),
    ("hash_deep_tuple", _a("x = ()\nfor i in range(2 * 10 ** 5):\n    x = (x,)\ns = {x}\nreturn True, 'x'"),
     "either", "died|deadline"),  # a C stack overflow; building the tuple can overrun on a loaded machine
    ("dict_comprehension_huge", _a("d = {i: i for i in range(10 ** 9)}\nreturn True, 'x'"), "either",
     "MemoryError|deadline"),
]
"""Denial of service: deadline (the frame is a fault and the worker replaced), memory limit, recursion
limit, or a crashed worker."""

HOST_OUTPUT: list[tuple[str, str, str, str]] = [
    ("reason_ten_megabytes", _a("return True, 'spam ' * (2 * 10 ** 6)"), "clean", "spam"),
    ("reason_ansi_escapes", _a("return True, '\\x1b[2J\\x1b[31mALARM\\x1b[0m\\x07'"), "clean", "ALARM"),
    ("reason_carriage_returns", _a("return True, 'line one\\r\\nline two\\rover'"), "clean", "line two"),
    ("reason_nul_bytes", _a("return True, 'a\\x00b\\x00c'"), "clean", "a b c"),
    ("reason_function_address", _a("return True, f'{distance}'"), "clean", "0x?"),
    ("reason_history_repr", _a("return True, '%s' % (H,)"), "clean", "0x?"),
    ("reason_repr_of_np", _a("return True, repr(np)"), "clean", "module"),
    ("reason_lone_surrogate", _a("return True, 'bad \\ud800 text'"), "clean", "bad"),
    ("reason_wide_characters", _a("return True, '\\U0001F916' * 5000"), "clean", "\U0001F916"),
    ("reason_huge_array_str", _a("return True, str(np.zeros((1000, 1000)))"), "clean", "0."),
    ("reason_format_fill", _a("return True, format('bell', '\\x07<60')"), "clean", "bell"),
    ("margin_positive_inf", _a("return True, 'x', math.inf"), "fault", "not finite"),
    ("margin_negative_inf", _a("return False, 'x', -np.inf"), "fault", "not finite"),
    ("margin_overflow", _a("return True, 'x', 1e308 * 10"), "fault", "not finite"),
    ("margin_huge_int", _a("return True, 'x', 10 ** 400"), "fault", "not finite"),
    ("margin_numpy_nan", _a("return True, 'x', np.float64('nan')"), "fault", "not finite"),
    ("margin_complex", _a("return True, 'x', 1j"), "fault", "margin must be a float"),
    ("margin_bool", _a("return True, 'x', True"), "fault", "margin must be a float"),
    ("margin_zero_d_array", _a("return True, 'x', np.array(1.0)"), "fault", "margin must be a float"),
    ("margin_list", _a("return True, 'x', [1.0]"), "fault", "margin must be a float"),
    ("ok_zero_d_array", _a("return np.array(True), 'x'"), "fault", "ok must be a bool"),
    ("ok_none", _a("return None, 'x'"), "fault", "ok must be a bool"),
    ("ok_float_nan", _a("return float('nan'), 'x'"), "fault", "ok must be a bool"),
    ("ok_string_true", _a("return 'True', 'x'"), "fault", "ok must be a bool"),
    ("result_list", _a("return [True, 'x']"), "fault", "returned list"),
    ("result_dict", _a("return {'ok': True}"), "fault", "returned dict"),
    ("result_nested_tuple", _a("return (True, 'x'), 'y'"), "fault", "ok must be a bool"),
    ("result_million_tuple", _a("return tuple([True] * 10 ** 6)"), "fault", "length 1000000"),
    ("result_mapping", _a("return E"), "fault", "returned mappingproxy"),
    ("reason_is_array", _a("return True, E[0]"), "fault", "reason must be a str"),
    ("print_flood", _a("for i in range(1000):\n    print('x' * 10000)\nreturn True, 'printed'"), "clean",
     "printed"),
]
"""Attacks on the control process through what a check returns: cut, cleaned, or a fault."""

INPUTS_AND_STATE: list[tuple[str, str, str, str]] = [
    ("inplace_add_input", _a("p = E[0]\np += 1.0\nreturn True, 'x'"), "fault", "read-only"),
    ("write_history_alias", _a("h = H[1]\nh[0, 0, 0] = 9.0\nreturn True, 'x'"), "fault", "read-only"),
    ("write_times_alias", _a("ts = H.t\nts[0] = -1.0\nreturn True, 'x'"), "fault", "read-only"),
    ("history_subscript_store", _a("H[0][0] = 1\nreturn True, 'x'"), "rejected", "must not modify"),
    ("times_augassign", _a("H.t += 1\nreturn True, 'x'"), "rejected", "attribute"),
    ("mapping_pop", _a("E.pop(0)\nreturn True, 'x'"), "rejected", "'.pop'"),
    ("mapping_clear", _a("E.clear()\nreturn True, 'x'"), "rejected", "'.clear'"),
    ("array_sort_in_place", _a("E[1].sort()\nreturn True, 'x'"), "rejected", "'.sort'"),
    ("array_fill", _a("E[1].fill(0.0)\nreturn True, 'x'"), "rejected", "'.fill'"),
    ("helper_attribute", _a("distance.cache = {}\nreturn True, 'x'"), "rejected", "attribute"),
    ("np_attribute_plant", _a("np.pi = 3.0\nreturn True, 'x'"), "rejected", "attribute"),
    ("ufunc_at_on_input", _a("np.add.at(E[0], [0], 5.0)\nreturn True, 'x'"), "rejected", "'.at'"),
    ("ufunc_out_into_input", _a("np.negative(E[0], out=E[0])\nreturn True, 'x'"), "rejected", "'out='"),
    ("global_random_state", _a("np.random.seed(1)\nreturn True, 'x'"), "rejected", "np.random"),
    ("mapping_setitem", _a("m = E\nm[5] = E[0]\nreturn True, 'x'"), "fault", "TypeError"),
    ("history_setitem", _a("hh = H\nhh[0] = 1\nreturn True, 'x'"), "fault", "TypeError"),
    ("copy_and_mutate", _a("d = E.copy()\nd[0] = np.zeros((1, 3))\nreturn True, 'copied'"), "clean", "copied"),
    ("module_state_counter", "SEEN = []\n\n" + _a("SEEN.append(t)\nreturn True, f'seen {len(SEEN)}'"), "clean",
     "seen 1"),
    ("load_time_loop", _top("X = sum(range(10 ** 11))"), "load", "did not finish"),
    ("load_time_memory", _top("X = 'a' * 10 ** 10"), "load", "MemoryError"),
    ("load_time_numpy_memory", _top("X = np.ones(10 ** 10)"), "load", "MemoryError"),
    ("load_time_call_check", _top("Y = distance(None, None)"), "load", "failed to load"),
    ("load_time_recursion", "def f(n):\n    return f(n + 1)\n\n\nX = f(0)\n\n" + _a("return True, 'x'"), "load",
     "RecursionError"),
]
"""Writes into the inputs, planted state, and module-level code run at load."""

WRITES_AND_FILES: list[tuple[str, str, str, str]] = [
    ("flags_writeable", _a("f = E[0].flags\nf.writeable = True\nE[0][0, 0] = 99.0\nreturn True, 'x'"), "rejected",
     "'.flags'"),
    ("copyto_input", _a("np.copyto(E[0], 7.0)\nreturn True, 'x'"), "rejected", "np.copyto"),
    ("put_into_input", _a("np.put(E[0], [0], [5.0])\nreturn True, 'x'"), "rejected", "np.put"),
    ("putmask_input", _a("np.putmask(E[0], E[0] > -1, 3.0)\nreturn True, 'x'"), "rejected", "np.putmask"),
    ("fill_diagonal_input", _a("np.fill_diagonal(E[1], 9.0)\nreturn True, 'x'"), "rejected", "np.fill_diagonal"),
    ("resize_input", _a("E[1].resize((2, 2), refcheck=False)\nreturn True, 'x'"), "rejected", "'.resize'"),
    ("pickle_input", _a("s = E[0].dumps()\nreturn True, str(len(s))"), "rejected", "'.dumps'"),
    ("masked_dump", _a(f"np.ma.dump(np.ma.array([1]), '{CANARY}')\nreturn True, 'x'"), "rejected", "np.ma"),
    ("savez_file", _a(f"np.savez('{CANARY}', a=E[0])\nreturn True, 'x'"), "rejected", "np.savez"),
    ("record_fromfile", _a("a = np.rec.fromfile('/etc/passwd', formats='u1')\nreturn True, 'x'"), "rejected",
     "np.rec"),
    ("genfromtxt_read", _a("a = np.genfromtxt('/etc/passwd')\nreturn True, 'x'"), "rejected", "np.genfromtxt"),
    ("fromregex_read", _a("a = np.fromregex('/etc/passwd', 'x', float)\nreturn True, 'x'"), "rejected",
     "np.fromregex"),
    ("datasource_open", _a("d = np.DataSource()\nreturn True, 'x'"), "rejected", "np.DataSource"),
    ("error_callback", _a("np.seterrcall(len)\nreturn True, 'x'"), "rejected", "np.seterrcall"),
    ("show_config_stdout", _a("np.show_config()\nreturn True, 'x'"), "rejected", "np.show_config"),
    ("generator_throw", _a("g = (x for x in [1])\ng.throw(ValueError)\nreturn True, 'x'"), "rejected", "'.throw'"),
    ("print_to_stdout", _a("print('HOSTILE-STDOUT')\nreturn True, 'printed'"), "clean", "printed"),
]
"""In-place writes through numpy functions and methods, files through numpy's readers and writers, global numpy
callbacks, and the worker's own stdout (the session of 2026-11-29, thirteenth: written before reading the lists)."""

ALL: list[tuple[str, str, str, str]] = (REFLECTION + NUMPY_MEMORY + DENIAL + HOST_OUTPUT + INPUTS_AND_STATE
                                        + WRITES_AND_FILES)
