"""``${...}`` templates in assemblies: parameter references and integer arithmetic.

Assemblies never ``eval`` strings. A template may reference parameters
(``${k}``, ``${robot.modules}``) and combine numbers with ``+ - * / // %``
and parentheses (``${i+1}``, ``${n*2}``): enough to chain repeated
sub-assemblies. The expression is parsed with :mod:`ast` and only those node
types are walked; anything else is an error naming the template.

A string that is exactly one template keeps the value's type (``"${k}"`` ->
2.5); templates inside a longer string are formatted into it (``seg${i}``).
A format spec after a colon pads systematic names: ``module_${n-1:02d}``.

Bounded: a format spec's width and precision are at most :data:`MAX_FORMAT_WIDTH`, a
formatted string at most :data:`MAX_STRING` characters, an integer result at most
:data:`MAX_INT_DIGITS` digits; beyond them the template is refused, naming the limit.
"""

from __future__ import annotations

import ast
import contextlib
import operator
import re

from .errors import ConfigError

_TEMPLATE = re.compile(r"\$\{([^}]*)\}")
#: widest format spec (``${i:0100d}``), characters
MAX_FORMAT_WIDTH = 100
#: longest string a template may format into, characters
MAX_STRING = 100_000
#: longest expression inside one ``${...}``, characters
MAX_EXPRESSION = 500
#: most digits of an integer a template computes
MAX_INT_DIGITS = 30
_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod}


def _lookup(path: str, scope: dict, expr: str):
    value = scope
    for part in path.split("."):
        if isinstance(value, dict) and part in value:
            value = value[part]
        else:
            known = ", ".join(sorted(scope)) or "none"
            raise ConfigError(f"'${{{expr}}}' references '{path}', which is not a parameter "
                              f"(parameters here: {known})")
    return value


def _eval(node, scope, expr):
    if isinstance(node, ast.Expression):
        return _eval(node.body, scope, expr)
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
        return node.value
    if isinstance(node, (ast.Name, ast.Attribute)):
        return _lookup(ast.unparse(node), scope, expr)
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        a, b = _number(_eval(node.left, scope, expr), expr), _number(_eval(node.right, scope, expr), expr)
        try:
            return _bounded(_BINOPS[type(node.op)](a, b), expr)
        except ZeroDivisionError:
            raise ConfigError(f"'${{{expr}}}': division by zero") from None
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        v = _number(_eval(node.operand, scope, expr), expr)
        return -v if isinstance(node.op, ast.USub) else v
    raise ConfigError(f"'${{{expr}}}': only parameter names, numbers, + - * / // % and "
                      f"parentheses are allowed in templates")


def _number(v, expr: str):
    """Arithmetic is on numbers only (no string repetition, no dict/list operators)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"'${{{expr}}}': arithmetic needs numbers, got {v!r}")
    return v


_FORMAT_SPEC = re.compile(r"^(?P<expr>.*?):(?P<spec>0?\d*(?:\.\d+)?[dfge]?)$")


def evaluate(expr: str, scope: dict):
    m = _FORMAT_SPEC.match(expr.strip())
    if m and m.group("spec"):
        # ${i+1:02d}: a Python format spec on the result, for zero-padded systematic names
        value = evaluate(m.group("expr"), scope)
        sizes = [int(x) for x in re.findall(r"\d+", m.group("spec"))]
        if any(x > MAX_FORMAT_WIDTH for x in sizes):
            raise ConfigError(f"'${{{expr}}}': format '{m.group('spec')}' is wider than {MAX_FORMAT_WIDTH} "
                              "characters (the limit)")
        try:
            return format(value, m.group("spec"))
        except (ValueError, TypeError):
            raise ConfigError(f"'${{{expr}}}': format '{m.group('spec')}' does not apply to {value!r}") from None
    if len(expr) > MAX_EXPRESSION:
        raise ConfigError(f"'${{{expr[:40]}...}}': an expression longer than {MAX_EXPRESSION} characters (the limit)")
    try:
        tree = ast.parse(expr.strip(), mode="eval")
        return _bounded(_eval(tree, scope, expr), expr)
    except (SyntaxError, RecursionError, MemoryError):
        raise ConfigError(f"'${{{expr}}}' is not a valid expression (or nests too deeply)") from None


def _bounded(v, expr: str):
    """Integers beyond :data:`MAX_INT_DIGITS` digits are refused (they cannot even be printed past
    Python's 4300-digit limit); every other value passes."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10 ** MAX_INT_DIGITS:
        raise ConfigError(f"'${{{expr}}}': the result has more than {MAX_INT_DIGITS} digits (the limit)")
    return v


def substitute(value, scope: dict):
    """Recursively expand templates in strings inside dicts/lists (positions kept)."""
    if isinstance(value, str):
        m = _TEMPLATE.fullmatch(value.strip())
        if m:
            return evaluate(m.group(1), scope)
        if "${" not in value:
            return value
        return _format_into(value, scope)
    if isinstance(value, dict):
        out = type(value)()
        _copy_position(value, out)
        for k, v in value.items():
            with _located(value, k):
                out[substitute(k, scope) if isinstance(k, str) else k] = substitute(v, scope)
        if hasattr(value, "pos"):
            out.pos = {substitute(k, scope) if isinstance(k, str) else k: ln for k, ln in value.pos.items()}
        return out
    if isinstance(value, list):
        items = []
        for n, v in enumerate(value):
            with _located(value, n):
                items.append(substitute(v, scope))
        out = type(value)(items)
        _copy_position(value, out)
        return out
    return value


@contextlib.contextmanager
def _located(container, key):
    """Give a template error the file:line of the innermost located key holding it."""
    try:
        yield
    except ConfigError as e:
        where = container.where(key) if e.where is None and hasattr(container, "where") else None
        if where is None:
            raise
        raise ConfigError(e.detail, where, e.key) from None


def _copy_position(src, dst) -> None:
    if hasattr(src, "file") and hasattr(dst, "__dict__"):
        dst.__dict__.update(src.__dict__)


def _format_into(text: str, scope: dict) -> str:
    """``text`` with each template formatted in; refused past :data:`MAX_STRING` characters."""
    parts, size, at = [], 0, 0
    for m in _TEMPLATE.finditer(text):
        piece = _format(evaluate(m.group(1), scope))
        parts += [text[at:m.start()], piece]
        size += m.start() - at + len(piece)
        at = m.end()
        if size > MAX_STRING:
            raise ConfigError(f"'{text[:40]}...' formats into more than {MAX_STRING:,} characters (the limit)")
    parts.append(text[at:])
    return "".join(parts)


def _format(v) -> str:
    if isinstance(v, float) and v.is_integer():
        return str(int(v))
    return str(v)
