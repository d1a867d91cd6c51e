"""What descriptions write in ``${...}`` still works, exactly as the ``xacro`` package does it.

``fixtures/zoo`` uses what published descriptions use: YAML read with
``xacro.load_yaml`` (keys as attributes, ``!degrees``), macros with defaults and
blocks, a namespaced include, ``xacro:if``, math names, ``python.*``, string
methods, comprehensions, ``%`` formatting and ``$(eval)``. Its expansion is
compared with what the ``xacro`` command prints for it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from server.sandbox import Confinement, Packages, SandboxError, expand_xacro
from tests.urdf.real_xacro import real_xacro

ZOO = Path(__file__).parent / "fixtures" / "zoo" / "zoo.urdf.xacro"


def ours(path: Path, args: dict[str, str] | None = None) -> str:
    return expand_xacro(path, args or {}, Packages({}, path.parent), Confinement()).text


@pytest.mark.parametrize("args", [{}, {"prefix": "r_", "scale": "3"}])
def test_the_zoo_expands_as_the_xacro_command_expands_it(args: dict[str, str]) -> None:
    theirs = real_xacro(ZOO, args, {})
    assert theirs.returncode == 0, theirs.stderr
    assert ours(ZOO, args) == theirs.stdout


@pytest.mark.parametrize(
    ("expression", "refusal"),
    [
        ("python.type(1)", "'type' is not allowed"),
        ("python.vars(python)", "'vars' is not allowed"),
        ("python.isinstance(1, python.int)", "'isinstance' is not allowed"),
        ("math.pi.__class__", "names starting with '_' are not allowed"),
        ("'x'.format", "attribute 'format' of a str is not allowed"),
        ("xacro.load_yaml.__globals__", "names starting with '_' are not allowed"),
        ("xacro.tokenize('a').append", "attribute 'append' of a list is not allowed"),
        ("(lambda: 1)()", "Lambda is not available"),
        ("[x for x in python.range(20000)]", "Comprehension generates too many elements"),
        ("'a' * 200000", "Sorry, I will not evaluate something that long"),
    ],
)
def test_what_reaches_python_is_refused(expression: str, refusal: str, tmp_path: Path) -> None:
    path = tmp_path / "r.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        f'<link name="a${{{expression}}}"/></robot>'
    )
    with pytest.raises(SandboxError, match="xacro: ") as caught:
        ours(path)
    assert refusal in str(caught.value)
