"""Evaluate FabHaL expressions; every failure is a located diagnostic."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from fabhal.diagnostics import Diagnostic, FabhalError, error
from fabhal.syntax import ast
from fabhal.syntax.hints import did_you_mean, suggestion

Value = float | bool

# Every number a program computes lies within this (a kilometre, in millimetres):
# far beyond any hack, and small enough that the solver's squares and sums stay
# exact to well under a micrometre; infinities and NaN never get past here.
MAGNITUDE_LIMIT = 1e6

_DEG = math.pi / 180.0
FUNCTIONS: dict[str, tuple[int, Callable[..., float]]] = {
    "sqrt": (1, math.sqrt),
    "abs": (1, abs),
    "sin": (1, lambda d: math.sin(d * _DEG)),
    "cos": (1, lambda d: math.cos(d * _DEG)),
    "tan": (1, lambda d: math.tan(d * _DEG)),
    "min": (2, min),
    "max": (2, max),
}


def evaluate(expr: ast.Expr, env: Mapping[str, Value]) -> Value:
    """The value of `expr` with names bound by `env`; raises FabhalError (E22x),
    E224 for a value that is not finite or beyond MAGNITUDE_LIMIT."""
    value = _value(expr, env)
    if not isinstance(value, bool) and not (math.isfinite(value) and abs(value) <= MAGNITUDE_LIMIT):
        raise FabhalError([_out_of_range(expr, value)])
    return value


def _out_of_range(expr: ast.Expr, value: float) -> Diagnostic:
    if isinstance(expr, ast.Number) and expr.text:
        what = f"`{expr.text}`"
    else:
        what = f"this expression ({f'{value:g}' if math.isfinite(value) else 'not a finite number'})"
    return error(
        "E224",
        f"{what} is out of range: numbers lie within ±{MAGNITUDE_LIMIT:,.0f}",
        expr.span,
        "lengths are in millimetres, angles in degrees and masses in grams; "
        "a number this large is almost always a typo",
    )


def _value(expr: ast.Expr, env: Mapping[str, Value]) -> Value:
    if isinstance(expr, ast.Number):
        return expr.value
    if isinstance(expr, ast.Boolean):
        return expr.value
    if isinstance(expr, ast.Name):
        if expr.name in env:
            return env[expr.name]
        help_text = suggestion(
            expr.name,
            env,
            "the names known here: {choices}",
            "no names are defined here; declare it with `param`",
        )
        raise FabhalError(
            [error("E220", f"unknown name `{expr.name}` in an expression", expr.span, help_text)]
        )
    if isinstance(expr, ast.Negation):
        return -number(expr.operand, env)
    if isinstance(expr, ast.FunctionCall):
        return _call(expr, env)
    left, right = number(expr.left, env), number(expr.right, env)
    if expr.op == "+":
        return left + right
    if expr.op == "-":
        return left - right
    if expr.op == "*":
        return left * right
    if right == 0:
        raise FabhalError([error("E221", "division by zero", expr.span, "check the divisor's value")])
    return left / right


def number(expr: ast.Expr, env: Mapping[str, Value]) -> float:
    """Evaluate an expression that must be a number (not true/false)."""
    value = evaluate(expr, env)
    if isinstance(value, bool):
        raise FabhalError(
            [error("E223", "expected a number, found true/false", expr.span, "write a number here")]
        )
    return float(value)


def _call(expr: ast.FunctionCall, env: Mapping[str, Value]) -> float:
    if expr.function not in FUNCTIONS:
        suggestion = did_you_mean(expr.function, FUNCTIONS)
        listed = ", ".join(f"`{f}`" for f in FUNCTIONS)
        help_text = f"did you mean `{suggestion}`?" if suggestion else f"the functions are {listed}"
        raise FabhalError([error("E222", f"unknown function `{expr.function}`", expr.span, help_text)])
    arity, function = FUNCTIONS[expr.function]
    if len(expr.args) != arity:
        raise FabhalError(
            [
                error(
                    "E222",
                    f"`{expr.function}` takes {arity} value{'s' if arity > 1 else ''}, not {len(expr.args)}",
                    expr.span,
                    f"write `{expr.function}({', '.join(['x', 'y'][:arity])})`",
                )
            ]
        )
    values = [number(a, env) for a in expr.args]
    try:
        return float(function(*values))
    except ValueError:
        raise FabhalError(
            [
                error(
                    "E221",
                    f"`{expr.function}` is undefined for {values[0]:g}",
                    expr.span,
                    "`sqrt` needs a value of at least 0",
                )
            ]
        ) from None
