"""AST -> canonical FabHaL text. `parse(format_module(m))` equals `m` up to spans."""

from __future__ import annotations

from fabhal.syntax import ast

_PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2}
_INDENT = "  "


def format_expr(expr: ast.Expr, parent_precedence: int = 0, right_side: bool = False) -> str:
    if isinstance(expr, ast.Number):
        return expr.text or repr(expr.value)
    if isinstance(expr, ast.Boolean):
        return "true" if expr.value else "false"
    if isinstance(expr, ast.Name):
        return expr.name
    if isinstance(expr, ast.Negation):
        operand = format_expr(expr.operand, 3)
        return "-" + (f"({operand})" if operand.startswith("-") else operand)  # never `--`
    if isinstance(expr, ast.FunctionCall):
        return f"{expr.function}({', '.join(format_expr(a) for a in expr.args)})"
    precedence = _PRECEDENCE[expr.op]
    text = f"{format_expr(expr.left, precedence)} {expr.op} {format_expr(expr.right, precedence, True)}"
    # left-associative: a right operand of equal precedence needs parentheses
    needs_parens = precedence < parent_precedence or (right_side and precedence == parent_precedence)
    return f"({text})" if needs_parens else text


def _vector(vector: ast.Vector) -> str:
    return f"({format_expr(vector.x)}, {format_expr(vector.y)}, {format_expr(vector.z)})"


def _placement(placement: ast.Placement | None) -> str:
    if placement is None:
        return ""
    parts = []
    if placement.position is not None:
        parts.append(f"at {_vector(placement.position)}")
    if placement.rotation is not None:
        parts.append(f"rot {_vector(placement.rotation)}")
    return " " + " ".join(parts)


def _arguments(args: tuple[ast.Argument, ...]) -> str:
    return ", ".join(f"{a.name}: {format_expr(a.value)}" for a in args)


def _lvalue(lvalue: ast.Lvalue) -> str:
    return lvalue.name if lvalue.index is None else f"{lvalue.name}[{format_expr(lvalue.index)}]"


def format_ref(ref: ast.Ref) -> str:
    return _lvalue(ref.base) + (f".{ref.primitive}" if ref.primitive else "")


def _call(call: ast.Call) -> str:
    return f"{call.callee}({_arguments(call.args)})"


def _domain(domain: ast.Domain) -> str:
    if isinstance(domain, ast.RangeDomain):
        return f"{format_expr(domain.low)} .. {format_expr(domain.high)}"
    if isinstance(domain, ast.LinspaceDomain):
        values = (domain.start, domain.stop, domain.count)
        return f"linspace({', '.join(format_expr(v) for v in values)})"
    return f"[{', '.join(format_expr(i) for i in domain.items)}]"


def _part_param(param: ast.PartParam) -> str:
    text = param.name
    if param.low is not None and param.high is not None:
        text += f": {format_expr(param.low)} .. {format_expr(param.high)}"
    if param.default is not None:
        text += f" = {format_expr(param.default)}"
    return text


def _header(keyword: str, name: str, params: tuple[ast.PartParam, ...], description: str | None) -> str:
    text = f"{keyword} {name}"
    if params:
        text += f"({', '.join(_part_param(p) for p in params)})"
    if description is not None:
        text += f' "{description}"'
    return text + " {"


def _part_item(item: ast.PartItem) -> str:
    if isinstance(item, ast.MeshLine):
        return f'mesh "{item.path}"'
    if isinstance(item, ast.MassLine):
        return f"mass {format_expr(item.value)}"
    if isinstance(item, ast.MaterialLine):
        return f"material {item.name}"
    return f"{item.kind} {item.name}({_arguments(item.args)}){_placement(item.placement)}"


def _statement(statement: ast.Statement, depth: int) -> list[str]:
    pad = _INDENT * depth
    if isinstance(statement, ast.ImportStmt):
        return [f'{pad}import "{statement.path}"']
    if isinstance(statement, ast.ParamDecl):
        default = f" = {format_expr(statement.default)}" if statement.default is not None else ""
        return [f"{pad}param {statement.name} in {_domain(statement.domain)}{default}"]
    if isinstance(statement, ast.EnvironmentDecl):
        text = f"environment {_lvalue(statement.name)} = {_call(statement.call)}"
        return [pad + text + _placement(statement.placement)]
    if isinstance(statement, ast.InstanceDecl):
        return [f"{pad}{_lvalue(statement.name)} = {_call(statement.call)}"]
    if isinstance(statement, ast.AliasDecl):
        return [f"{pad}{_lvalue(statement.name)} = {format_ref(statement.ref)}"]
    if isinstance(statement, ast.ConnectStmt):
        options = "".join(f" {o.name}" for o in statement.options)
        settings = ", ".join(
            f"{format_ref(s.side)}.{s.dof}: {format_expr(s.value)}" for s in statement.settings
        )
        written = f" set ({settings})" if settings else ""
        return [f"{pad}connect {format_ref(statement.a)} -- {format_ref(statement.b)}{options}{written}"]
    if isinstance(statement, ast.TargetStmt):
        return [f"{pad}target {format_ref(statement.ref)}{_placement(statement.placement)}"]
    if isinstance(statement, ast.PortDecl):
        return [f"{pad}port {statement.name} = {format_ref(statement.ref)}"]
    if isinstance(statement, ast.MaterialDef):
        description = f' "{statement.description}"' if statement.description is not None else ""
        return [f"{pad}material {statement.name}({_arguments(statement.args)}){description}"]
    if isinstance(statement, ast.ForLoop):
        bounds = f"{format_expr(statement.low)} .. {format_expr(statement.high)}"
        head = f"{pad}for {statement.variable} in {bounds} {{"
        return [head, *_block(statement.body, depth + 1), pad + "}"]
    if isinstance(statement, ast.AssemblyDef):
        head = pad + _header("assembly", statement.name, statement.params, statement.description)
        return [head, *_block(statement.body, depth + 1), pad + "}"]
    head = pad + _header("part", statement.name, statement.params, statement.description)
    items = [_INDENT * (depth + 1) + _part_item(i) for i in statement.items]
    return [head, *items, pad + "}"]


def _block(statements: tuple[ast.Statement, ...], depth: int) -> list[str]:
    return [line for s in statements for line in _statement(s, depth)]


def format_module(module: ast.Module) -> str:
    return "\n".join(_block(module.statements, 0)) + "\n"
