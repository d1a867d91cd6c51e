"""Inside the worker process: a xacro file expanded by the ``xacro`` package, confined.

The ``xacro`` package does the expanding (macros, properties, includes,
arguments, its output text); what it would do with Python's ``eval`` or the
whole file system goes through this module instead:

- ``${...}`` and ``$(eval ...)``: ``expressions.SafeEval``, over xacro's names
  less those that reach the object graph;
- ``$(env)``, ``$(optenv)``: only the variables the robot's ``xacro_env``
  names (the process has no others anyway);
- ``$(find)``: ``Packages``, as ``package://`` is found;
- ``<xacro:include>`` and ``xacro.load_yaml``: only files inside the allowed
  folders (the cell's folder, the description's, its packages), symbolic links
  resolved first.

The worker is a fresh process for one file, so xacro's module globals are
changed here without restoring them.
"""

from __future__ import annotations

import io
import os
import xml.parsers.expat
from collections.abc import Callable, Mapping
from contextlib import redirect_stderr
from pathlib import Path
from typing import Any

from .expressions import (
    Namespace,
    SafeEval,
    builtin_names,
    math_names,
    python_namespace,
)
from .packages import PackageNotFound, Packages

ENV_HINT = "name it in the robot's kinematics.xacro_env"


class Confined:
    """Which folders the file may read from, growing with the ROS packages it finds."""

    def __init__(self, roots: list[Path], packages: Packages) -> None:
        self.roots = [root.resolve() for root in roots]
        self.packages = packages

    def find(self, name: str) -> str:
        """``$(find name)``: the package's folder; a ROS package found becomes readable."""
        try:
            folder = self.packages.require(name)
        except PackageNotFound as exc:
            raise PackageNotFound(f"$(find {name}): {exc}") from None
        if (folder / "package.xml").is_file() and folder.resolve() not in self.roots:
            self.roots.append(folder.resolve())
        return str(folder)

    def check(self, filename: str, what: str) -> None:
        """Raise PermissionError unless ``filename`` lies inside an allowed folder."""
        real = Path(filename).resolve()
        if not any(real == root or real.is_relative_to(root) for root in self.roots):
            raise PermissionError(
                f"{what} of {filename} refused: it is outside the cell's folder and the "
                f"description's packages ({', '.join(map(str, self.roots))})"
            )


def _symbols(xacro: Any, load_yaml: Callable[[str], Any]) -> dict[str, Any]:
    """xacro's global names (its ``create_global_symbols``) made safe (see ``expressions``)."""
    original = xacro._global_symbols
    ours = Namespace(original["xacro"])  # message, warning, error, fatal, tokenize, arg ...
    ours["load_yaml"] = load_yaml
    symbols: dict[str, Any] = builtin_names()
    symbols.update(math_names())
    python = python_namespace()
    symbols.update(
        python=python,
        math=Namespace(math_names()),
        xacro=ours,
        sorted=python["sorted"],
        range=python["range"],
        load_yaml=load_yaml,
        abs_filename=ours["abs_filename"],
        dotify=ours["dotify"],
    )
    return symbols


def _functions(symbols: Mapping[str, Any]) -> dict[str, Callable[..., Any]]:
    return {name: value for name, value in symbols.items() if callable(value)}


def _substitutions(
    sub: Any, env: Mapping[str, str], confined: Confined, functions: Mapping[str, Any]
) -> None:
    """``$(env)``, ``$(optenv)``, ``$(find)`` and ``$(eval)`` as the module doc says."""

    def env_value(name: str) -> str:
        if name not in env:
            raise sub.SubstitutionException(f"environment variable {name} is not set ({ENV_HINT})")
        return env[name]

    def optenv_value(name: str, default: str = "") -> str:
        return env.get(name, default)

    sub._eval_env = env_value
    sub._eval_optenv = optenv_value
    sub._eval_find = confined.find

    def evaluate(text: str, context: dict[str, Any]) -> str:
        args = context.setdefault("arg", {})
        names: dict[str, Any] = dict(math_names())
        names.update({k: functions[k] for k in ("list", "dict", "map", "str", "float", "int")})
        names.update(
            {"true": True, "false": False, "True": True, "False": False},
            env=env_value,
            optenv=optenv_value,
            find=confined.find,
            arg=lambda name: sub.convert_value(sub._eval_arg(name, args), "auto"),
            dirname=lambda: sub._eval_dirname(context["filename"]),
        )
        lookup = _EvalNames(names, args, sub.convert_value)
        evaluator = SafeEval(lookup, _functions(names))
        return str(evaluator.evaluate(text))

    sub._eval = evaluate


class _EvalNames(Mapping[str, Any]):
    """``$(eval)``'s names: its functions, then the xacro arguments (typed, as xacro does)."""

    def __init__(self, names: dict[str, Any], args: dict[str, str], convert: Any) -> None:
        self.names = names
        self.args = args
        self.convert = convert

    def __getitem__(self, key: str) -> Any:
        if key in self.names:
            return self.names[key]
        return self.convert(self.args[key], "auto")

    def __iter__(self) -> Any:
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)


def expand(request: Mapping[str, Any]) -> dict[str, Any]:
    """Expand ``request["file"]``; the answer the worker sends back (``text`` or ``error``)."""
    import xacro
    from xacro import substitution_args as sub

    path = Path(request["file"])
    given = {name: Path(folder) for name, folder in request["packages"].items()}
    packages = Packages(given, Path(request["start"]))
    confined = Confined([Path(r) for r in request["roots"]], packages)
    env = {name: os.environ[name] for name in request["env"] if name in os.environ}

    original_load_yaml = xacro.load_yaml
    original_parse = xacro.parse

    def load_yaml(filename: str) -> Any:
        confined.check(xacro.abs_filename_spec(filename), "xacro.load_yaml")
        return original_load_yaml(filename)

    def parse(inp: Any, filename: str | None = None) -> Any:
        if inp is None and filename is not None:
            try:
                confined.check(os.path.join(xacro.root_dir, filename), "reading")
            except PermissionError as exc:
                xacro.filestack.pop()  # as xacro's own parse does: report the including file
                raise xacro.XacroException(str(exc)) from None
        return original_parse(inp, filename)

    symbols = _symbols(xacro, load_yaml)
    xacro._global_symbols.clear()
    xacro._global_symbols.update(symbols)
    functions = _functions(symbols)
    keyed = (xacro.NameSpace, xacro.YamlDictWrapper)

    def safe_eval(expr: str, names: Any, _locals: Any = None) -> Any:
        return SafeEval(names, functions, keyed).evaluate(expr)

    xacro.safe_eval = safe_eval
    xacro.parse = parse
    _substitutions(sub, env, confined, functions)

    if not path.is_file():
        return {"error": f"xacro file {path} not found"}
    stderr = io.StringIO()
    xacro.all_includes = []
    try:
        with redirect_stderr(stderr):
            doc = xacro.process_file(str(path), mappings=dict(request["args"]))
        text = str(doc.toprettyxml(indent="  "))
    except Exception as exc:  # xacro evaluates the file's expressions: any error is the file's
        if isinstance(exc, MemoryError) or isinstance(getattr(exc, "exc", None), MemoryError):
            raise MemoryError from None  # the worker's memory limit: its exit status says so
        where = (xacro.filestack or [None])[-1] or path
        kind = "malformed XML" if isinstance(exc, xml.parsers.expat.ExpatError) else "xacro"
        inner = getattr(exc, "exc", None)  # xacro wraps what $(find) raised
        reason = inner if isinstance(inner, PackageNotFound | PermissionError) else exc
        return {"error": f"{where}: {kind}: {reason}", "warnings": _lines(stderr, path)}
    return {
        "text": text,
        "included": list(dict.fromkeys(str(name) for name in xacro.all_includes)),
        "warnings": _lines(stderr, path),
        "packages": {name: str(folder) for name, folder in packages.found.items()},
    }


def _lines(stderr: io.StringIO, path: Path) -> list[str]:
    return [f"{path}: xacro: {line}" for line in stderr.getvalue().splitlines() if line.strip()]
