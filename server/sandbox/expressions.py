"""``${...}`` and ``$(eval ...)`` evaluated without reaching Python's object graph.

xacro evaluates expressions with Python's ``eval`` and a short list of names,
which is no sandbox: through ``python.type``, ``python.vars``, a generator's
``gi_frame.f_back.f_globals`` or ``str.format``'s field lookups an expression
reaches modules and runs programs. Here simpleeval walks the expression's
syntax tree itself, and this module narrows it further to what robot
descriptions use:

- arithmetic, comparisons, ``a if c else b``, ``and``/``or``/``not``, strings,
  lists, tuples, dicts, comprehensions (evaluated to lists: no generator, so
  no frame), subscripts and slices;
- the names xacro offers (its math functions and constants, ``len``, ``str``,
  ``float``, ``int``, ``min``, ``max``, ``round``, ``sorted``, ``range`` ...,
  the ``math``, ``python`` and ``xacro`` namespaces) less ``type``, ``vars``,
  ``isinstance``, ``issubclass``, ``repr``, ``getattr`` and the like;
- attributes only where they are data: a namespace's names, a YAML mapping's
  keys, and a fixed list of methods of str, list, tuple, dict, int and float
  (never ``format``/``format_map``, never one starting with ``_``).

Numbers, strings and comprehensions are bounded as simpleeval bounds them
(exponent <= 4 000 000, strings <= 100 000 characters, comprehensions <= 10 000
items); whatever is still slow or large is stopped by the worker's limits.
"""

from __future__ import annotations

import ast
import builtins
import math
from collections.abc import Callable, Mapping
from typing import Any, cast

import simpleeval

# xacro's own names (create_global_symbols), without those that reach the object graph.
DIRECT = ("list", "dict", "map", "len", "str", "float", "int", "bool", "min", "max", "round")
PYTHON = DIRECT + (
    "abs", "all", "any", "complex", "divmod", "enumerate", "filter", "frozenset", "hash", "ord",
    "reversed", "slice", "set", "sum", "tuple", "zip", "sorted", "range",
)  # fmt: skip
REFUSED = ("type", "vars", "isinstance", "issubclass", "repr", "getattr", "eval", "exec")

_STR = (
    "capitalize", "casefold", "center", "count", "endswith", "expandtabs", "find", "index",
    "isalnum", "isalpha", "isdecimal", "isdigit", "islower", "isnumeric", "isspace", "istitle",
    "isupper", "join", "ljust", "lower", "lstrip", "partition", "removeprefix", "removesuffix",
    "replace", "rfind", "rindex", "rjust", "rpartition", "rsplit", "rstrip", "split",
    "splitlines", "startswith", "strip", "swapcase", "title", "upper", "zfill",
)  # fmt: skip
_NUMBER = ("real", "imag", "conjugate", "is_integer", "bit_length", "as_integer_ratio")
METHODS: dict[type, frozenset[str]] = {
    str: frozenset(_STR),
    list: frozenset(("count", "index", "copy")),
    tuple: frozenset(("count", "index")),
    dict: frozenset(("get", "keys", "values", "items", "copy")),
    int: frozenset(_NUMBER),
    float: frozenset(_NUMBER),
    bool: frozenset(_NUMBER),
}
"""Per exact type, the attributes an expression may read: pure methods returning data."""


class Namespace(dict[str, Any]):
    """Names reached with a dot (``math.pi``, ``xacro.load_yaml``): a plain mapping."""


def builtin_names() -> dict[str, Any]:
    """``DIRECT`` builtins by name."""
    return {name: getattr(builtins, name) for name in DIRECT}


def math_names() -> dict[str, Any]:
    """Every public name of ``math``, as xacro exposes them (directly and as ``math.``)."""
    return {k: v for k, v in vars(math).items() if not k.startswith("_")}


def python_namespace() -> Namespace:
    """xacro's ``python.`` namespace, less ``REFUSED``."""
    return Namespace({name: getattr(builtins, name) for name in PYTHON})


class ExpressionError(ValueError):
    """An expression uses what is not allowed here; the message says what."""


class SafeEval(simpleeval.EvalWithCompoundTypes):  # type: ignore[misc]
    """simpleeval narrowed to data (see the module doc).

    ``names`` is looked up as a mapping (xacro's symbol table, which resolves
    properties lazily); ``keyed`` are the types whose attributes are keys (xacro's
    namespace and YAML classes, which live in the worker's xacro module).
    """

    def __init__(
        self,
        names: Mapping[str, Any],
        functions: Mapping[str, Callable[..., Any]],
        keyed: tuple[type, ...] = (),
    ) -> None:
        super().__init__(functions=dict(functions), names=names)
        self.keyed = (Namespace, *keyed)
        self.nodes[ast.Name] = self._name

    def evaluate(self, expression: str) -> Any:
        """The value of ``expression`` (one Python expression, as xacro's ``eval`` takes)."""
        tree = ast.parse(expression.strip(), mode="eval")
        return self.eval(expression, previously_parsed=tree.body)

    def _name(self, node: ast.Name) -> Any:
        try:
            return self.names[node.id]
        except KeyError:
            pass
        if node.id in self.functions:
            return self.functions[node.id]
        # xacro's callers tell an unknown name by NameError (an include's file name, say).
        raise NameError(f"name '{node.id}' is not defined")

    def _eval_call(self, node: ast.Call) -> Any:
        if isinstance(node.func, ast.Name):
            func = self._name(node.func)
        else:
            func = self._eval(node.func)
        if not callable(func):
            raise ExpressionError(f"{type(func).__name__!r} object is not callable")
        _refuse_function(func)
        args = [self._eval(a) for a in node.args]
        kwargs = dict(self._eval(k) for k in node.keywords)
        return func(*args, **kwargs)

    def _eval_attribute(self, node: ast.Attribute) -> Any:
        name = node.attr
        if name.startswith("_"):
            raise ExpressionError(f"attribute {name!r}: names starting with '_' are not allowed")
        value = self._eval(node.value)
        if isinstance(value, self.keyed):  # a namespace's name or a YAML key, as xacro reads them
            try:
                return cast(Mapping[str, Any], value)[name]
            except KeyError:
                if name in REFUSED:
                    raise ExpressionError(
                        f"{name!r} is not allowed in a description's expression: it reaches "
                        "Python's objects, not data"
                    ) from None
                raise
        if name in _methods(value):
            return getattr(value, name)
        raise ExpressionError(
            f"attribute {name!r} of a {type(value).__name__} is not allowed in a description's "
            "expression (only namespace names, YAML keys and plain methods of strings, "
            "numbers, lists and dicts)"
        )

    def _eval_formattedvalue(self, node: ast.FormattedValue) -> Any:
        # simpleeval builds "{:" + spec + "}" and calls str.format on it, which would
        # read fields named in the spec; format() takes the spec as a spec only.
        value = self._eval(node.value)
        if node.conversion == ord("r"):
            raise ExpressionError("!r is not allowed in a description's expression")
        if node.conversion == ord("a"):
            value = ascii(value)
        elif node.conversion == ord("s"):
            value = str(value)
        spec = self._eval(node.format_spec) if node.format_spec is not None else ""
        return format(value, spec)


def _methods(value: Any) -> frozenset[str]:
    """The attributes ``value`` may be asked for: those of the built-in type it is."""
    # A subclass (xacro's YAML list) is one of the worker's own classes, never the file's.
    for kind in type(value).__mro__:
        if kind in METHODS:
            return METHODS[kind]
    return frozenset()


def _refuse_function(func: Any) -> None:
    try:
        refused = func in simpleeval.DISALLOW_FUNCTIONS or any(
            func is getattr(builtins, name, None) for name in REFUSED
        )
    except TypeError:  # an unhashable callable: none of the refused ones is
        refused = False
    if refused:
        raise ExpressionError(f"{getattr(func, '__name__', 'this function')} is not allowed")
