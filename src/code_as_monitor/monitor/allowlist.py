"""The allow-lists of monitor programs: names, builtins and attributes a program may use.

Kept apart from :mod:`.validate` so the coder prompt (and a reader) can see the whole surface in one
place. Everything not listed here is rejected.
"""

from __future__ import annotations

from code_as_monitor.geometry.helpers import MONITOR_HELPERS

SAFE_BUILTINS: frozenset[str] = frozenset({
    "abs", "min", "max", "len", "range", "float", "int", "bool", "str", "round", "sum", "any", "all",
    "enumerate", "zip", "sorted", "reversed", "list", "tuple", "dict", "set", "isinstance", "divmod",
    "print", "repr", "format", "True", "False", "None",
})
"""Builtins the worker namespace provides (``print`` is a no-op there)."""

NAMESPACE: frozenset[str] = frozenset({"np", "math", *MONITOR_HELPERS})

BANNED_NAMES: frozenset[str] = frozenset({
    "exec", "eval", "open", "getattr", "setattr", "delattr", "hasattr", "globals", "locals", "vars",
    "compile", "__import__", "__builtins__", "input", "breakpoint", "help", "dir", "type", "object",
    "super", "memoryview", "bytearray", "bytes", "classmethod", "staticmethod", "property", "id",
    "exit", "quit", "iter", "next", "callable", "issubclass", "os", "sys", "ctypes",
    "subprocess", "builtins", "importlib",
})

NP_ALLOWED: frozenset[str] = frozenset({
    # constants and scalar types
    "pi", "e", "inf", "nan", "newaxis", "float64", "float32", "int64", "int32", "bool_", "ndarray", "integer",
    "floating",
    # construction
    "array", "asarray", "zeros", "ones", "zeros_like", "ones_like", "full", "eye", "identity", "arange",
    "linspace", "stack", "vstack", "hstack", "column_stack", "concatenate", "tile", "repeat",
    # linear algebra and products
    "linalg", "dot", "vdot", "inner", "outer", "cross", "matmul", "trace",
    # reductions and statistics
    "sum", "mean", "median", "min", "max", "amin", "amax", "std", "var", "percentile", "ptp", "prod",
    "cumsum", "diff", "argmin", "argmax", "argsort", "sort", "count_nonzero", "nonzero", "where",
    "nanmean", "nanmin", "nanmax", "all", "any", "unique", "gradient", "interp", "average",
    # element-wise maths
    "abs", "absolute", "sign", "sqrt", "square", "power", "exp", "log", "log10", "sin", "cos", "tan",
    "arcsin", "arccos", "arctan", "arctan2", "degrees", "radians", "deg2rad", "rad2deg", "hypot",
    "minimum", "maximum", "clip", "round", "floor", "ceil", "isfinite", "isnan", "isinf", "isclose",
    "allclose", "array_equal", "logical_and", "logical_or", "logical_not", "logical_xor",
    # shape manipulation
    "reshape", "transpose", "squeeze", "expand_dims", "atleast_2d", "flip", "roll", "ravel",
})
"""Members of ``np`` a program may use. Anything touching files, raw memory or global state is absent."""

NP_LINALG_ALLOWED: frozenset[str] = frozenset({
    "norm", "det", "inv", "pinv", "solve", "svd", "eig", "eigh", "lstsq", "matrix_rank", "qr",
})

MATH_ALLOWED: frozenset[str] = frozenset({
    "pi", "e", "tau", "inf", "nan", "sqrt", "hypot", "dist", "sin", "cos", "tan", "asin", "acos",
    "atan", "atan2", "degrees", "radians", "isfinite", "isnan", "isinf", "isclose", "fabs", "floor",
    "ceil", "exp", "log", "log10", "log2", "copysign", "fsum", "trunc",
})

VALUE_ATTRS: frozenset[str] = frozenset({
    # arrays
    "T", "shape", "ndim", "size", "mean", "sum", "min", "max", "std", "var", "tolist", "copy", "reshape",
    "flatten", "ravel", "item", "any", "all", "argmin", "argmax", "clip", "round", "dot", "cumsum",
    "squeeze", "transpose", "prod", "astype", "argsort", "nonzero",
    # lists, dicts, strings
    "append", "extend", "items", "keys", "values", "get", "index", "count", "join", "upper", "lower",
    "strip", "startswith", "endswith", "split",
    # the history's timestamps
    "t",
})
"""Attributes allowed on any value that is not ``np``, ``np.linalg``, ``math`` or ``H``."""

DTYPES: frozenset[str] = frozenset({
    "float", "int", "bool", "complex", "float64", "float32", "int64", "int32", "bool_", "complex128", "f8", "f4",
    "i8", "i4", "?", "b1",
})
"""What a ``dtype=`` argument or ``.astype(...)`` may name: the builtins ``float``/``int``/``bool``/``complex``,
``np.<name>`` or a string literal from this set. Never objects, records, bytes or datetimes."""

METHOD_MAX_POSITIONAL: dict[str, int] = {
    "sum": 1, "mean": 1, "std": 1, "var": 1, "prod": 1, "cumsum": 1, "min": 1, "max": 1, "argmin": 1,
    "argmax": 1, "any": 1, "all": 1, "round": 1, "dot": 1, "clip": 2, "astype": 1, "tolist": 0, "flatten": 0,
    "ravel": 0, "nonzero": 0, "argsort": 1, "squeeze": 1,
}
"""Positional arguments a method may take (beyond these, numpy methods take ``dtype``/``out``)."""
