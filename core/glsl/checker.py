"""Type checking and name binding: the syntax tree of a shader to a :class:`~core.glsl.program.Program`.

GLSL 1.20's rules as a BRDF Explorer shader meets them:

- int converts to float where a float is expected (arguments, assignment, mixed arithmetic); nothing else
  converts implicitly. Conditions (``if``, loops, ``?:``, ``&& || !``) must be bool.
- Operators: ``+ - * /`` component-wise, a scalar combining with every component of a vector; ``< > <= >=``
  on scalars; ``== !=`` on equal types. The bitwise operators and ``%`` are reserved words of GLSL 1.20.
- Names: functions must be declared (or prototyped) before they are called; variables come into scope after
  their initializer and may shadow outer ones; a local variable hides functions of its name. A user function
  with a built-in's name hides every overload of that built-in (GLSL 1.20's redeclaration rule). No recursion.
- Overloads: an exact match wins, otherwise the one candidate reachable by int-to-float conversions (the one
  with the fewest, if several).
- Parameters of the ``.brdf`` file are uniforms (read-only); ``const`` variables need a constant initializer.
- ``vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)`` must be defined; every function that returns a value
  must return one on every path.

Every error is a :class:`ShaderError` at the offending token, in the ``.brdf`` file's lines.
"""

from __future__ import annotations

from collections.abc import Sequence

from core.glsl import program as p
from core.glsl import syntax as s
from core.glsl.brdf_file import ShaderParam
from core.glsl.builtin_functions import BUILTINS, Overload
from core.glsl.errors import ShaderError
from core.glsl.types import (
    BOOL,
    FLOAT,
    INT,
    TYPES_BY_NAME,
    VEC3,
    VOID,
    GlslType,
    float_type,
    implicitly_converts,
)

BRDF_SIGNATURE = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)"
_SWIZZLE_SETS = ("xyzw", "rgba", "stpq")
_RESERVED_OPERATORS = {"%", "<<", ">>", "&", "|", "^", "~"}
_COMPOUND_OPERATORS = {"+=": "+", "-=": "-", "*=": "*", "/=": "/"}
_INT_MIN, _INT_MAX = -(2**31), 2**31 - 1


def check_program(
    unit: s.TranslationUnit, params: Sequence[ShaderParam], path: str, shader_line: int = 1
) -> p.Program:
    """Check ``unit`` (the shader of the file ``path``, beginning on its line ``shader_line``, whose parameters
    are ``params``) and bind its names.

    Raises
    ------
    ShaderError
        The first error found, at its place in the file.
    """
    return _Checker(path, params, shader_line).run(unit)


def _kind_type(param: ShaderParam) -> GlslType:
    return {"float": FLOAT, "color": VEC3, "bool": BOOL}[param.kind]


def _always_returns(statement: p.Stmt) -> bool:
    if isinstance(statement, p.Return):
        return True
    if isinstance(statement, p.Block):
        return any(_always_returns(child) for child in statement.statements)
    if isinstance(statement, p.If):
        return (
            statement.otherwise is not None
            and _always_returns(statement.then)
            and _always_returns(statement.otherwise)
        )
    if isinstance(statement, p.Loop) and not statement.test_first:
        return _always_returns(statement.body)
    return False


def is_constant(expr: p.Expr) -> bool:
    """GLSL's constant expressions: literals, const variables (not const parameters), and operators,
    constructors and built-in calls on constant expressions."""
    if isinstance(expr, p.Constant):
        return True
    if isinstance(expr, p.VariableRef):
        return expr.variable.is_const and expr.variable.kind in ("local", "global")
    if isinstance(expr, p.Convert | p.Swizzle | p.Unary):
        return is_constant(expr.operand)
    if isinstance(expr, p.IndexOf):
        return is_constant(expr.operand) and is_constant(expr.index)
    if isinstance(expr, p.Arithmetic | p.Compare | p.Logical):
        return is_constant(expr.left) and is_constant(expr.right)
    if isinstance(expr, p.Select):
        return all(is_constant(e) for e in (expr.condition, expr.if_true, expr.if_false))
    if isinstance(expr, p.Construct | p.CallBuiltin | p.Sequence):
        return all(is_constant(a) for a in (expr.items if isinstance(expr, p.Sequence) else expr.args))
    return False


def _calls_function(expr: p.Expr) -> bool:
    if isinstance(expr, p.CallFunction):
        return True
    return any(_calls_function(child) for child in _children(expr))


def _children(expr: p.Expr) -> tuple[p.Expr, ...]:
    if isinstance(expr, p.Constant | p.VariableRef):
        return ()
    if isinstance(expr, p.Convert | p.Swizzle | p.Unary):
        return (expr.operand,)
    if isinstance(expr, p.IndexOf):
        return (expr.operand, expr.index)
    if isinstance(expr, p.Arithmetic | p.Compare | p.Logical):
        return (expr.left, expr.right)
    if isinstance(expr, p.Select):
        return (expr.condition, expr.if_true, expr.if_false)
    if isinstance(expr, p.Assign):
        return (expr.target, expr.value)
    if isinstance(expr, p.Update):
        return (expr.target,)
    if isinstance(expr, p.Sequence):
        return expr.items
    return expr.args


def _describe(types: Sequence[GlslType]) -> str:
    return ", ".join(str(t) for t in types)


class _Checker:
    def __init__(self, path: str, params: Sequence[ShaderParam], shader_line: int) -> None:
        self.path = path
        self.shader_line = shader_line
        self.scopes: list[dict[str, p.Variable]] = [{}]
        self.functions: dict[str, list[p.Function]] = {}
        self.defined: list[p.Function] = []
        self.first_calls: dict[p.Function, s.Position] = {}
        self.globals: list[p.GlobalVariable] = []
        self.global_reads: set[p.Variable] = set()
        self.current: p.Function | None = None
        self.loop_depth = 0
        slot = 0
        uniforms = []
        for param in params:
            variable = p.Variable(param.name, _kind_type(param), "uniform", True, s.Position(0, 0), slot)
            slot += param.slot_count
            uniforms.append(variable)
            self.scopes[0][param.name] = variable
        self.uniforms = tuple(uniforms)

    def line(self, pos: s.Position) -> int:
        """The ``.brdf`` file's line of a position in the shader."""
        return pos.line + self.shader_line - 1

    def error(self, pos: s.Position, message: str) -> ShaderError:
        return ShaderError(self.path, self.line(pos), pos.column, message)

    # ---- the translation unit

    def run(self, unit: s.TranslationUnit) -> p.Program:
        for item in unit.items:
            if isinstance(item, s.FunctionDeclaration):
                self.function(item)
            else:
                self.global_declaration(item)
        for function, pos in self.first_calls.items():
            if function.body is None:
                raise self.error(pos, f"function '{function.signature()}' is declared but never defined")
        self.check_recursion()
        brdf = self.find_brdf()
        reachable = self.reachable(brdf)
        reads = set(self.global_reads).union(*(f.reads for f in reachable))
        x_axis, y_axis = brdf.params[3], brdf.params[4]
        return p.Program(
            uniforms=self.uniforms,
            globals=tuple(self.globals),
            functions=tuple(self.defined),
            brdf=brdf,
            uses_tangents=x_axis in brdf.reads or y_axis in brdf.reads,
            reads_uniforms=frozenset(v.name for v in reads if v.kind == "uniform"),
        )

    def find_brdf(self) -> p.Function:
        candidates = [f for f in self.functions.get("BRDF", []) if f.body is not None]
        for function in candidates:
            if function.result == VEC3 and function.param_types == (VEC3,) * 5:
                return function
        if candidates:
            raise self.error(
                candidates[0].pos,
                f"BRDF must be declared as '{BRDF_SIGNATURE}', not '{candidates[0].signature()}'",
            )
        raise self.error(s.Position(1, 1), f"the shader does not define '{BRDF_SIGNATURE}'")

    def reachable(self, root: p.Function) -> list[p.Function]:
        seen: list[p.Function] = []
        stack = [root]
        while stack:
            function = stack.pop()
            if function in seen:
                continue
            seen.append(function)
            stack.extend(function.callees)
        return seen

    def check_recursion(self) -> None:
        state: dict[p.Function, int] = {}  # 1 on the current path, 2 done

        def visit(function: p.Function) -> None:
            state[function] = 1
            for callee, pos in function.callees.items():
                if state.get(callee) == 1:
                    raise self.error(
                        pos,
                        f"recursion is not allowed in GLSL ('{callee.name}' calls itself through this call)",
                    )
                if callee not in state:
                    visit(callee)
            state[function] = 2

        for function in self.defined:
            if function not in state:
                visit(function)

    # ---- declarations

    def type_of(self, type_name: s.TypeName) -> GlslType:
        return TYPES_BY_NAME[type_name.name]

    def global_declaration(self, declaration: s.Declaration) -> None:
        is_const = self.qualifiers(declaration.qualifiers, "variable")
        var_type = self.type_of(declaration.type_name)
        if var_type == VOID:
            raise self.error(declaration.type_name.pos, "a variable cannot be void")
        for declarator in declaration.declarators:
            previous = self.scopes[0].get(declarator.name)
            if previous is not None:
                raise self.error(declarator.pos, self.redeclaration(declarator.name, previous))
            if declarator.name in self.functions:
                raise self.error(declarator.pos, f"'{declarator.name}' is already declared as a function")
            initializer = None
            if declarator.initializer is not None:
                initializer = self.initializer(declarator, var_type, is_const)
                if _calls_function(initializer):
                    raise self.error(
                        declarator.pos, f"the initializer of global '{declarator.name}' calls a function"
                    )
            elif is_const:
                raise self.error(declarator.pos, f"const '{declarator.name}' needs an initializer")
            variable = p.Variable(declarator.name, var_type, "global", is_const, declarator.pos)
            self.scopes[0][declarator.name] = variable
            self.globals.append(p.GlobalVariable(variable, initializer))

    def initializer(self, declarator: s.Declarator, var_type: GlslType, is_const: bool) -> p.Expr:
        assert declarator.initializer is not None
        value = self.convert(
            self.expr(declarator.initializer), var_type, declarator.pos, f"initializing '{declarator.name}'"
        )
        if is_const and not is_constant(value):
            raise self.error(
                declarator.pos, f"the initializer of const '{declarator.name}' is not a constant expression"
            )
        return value

    def redeclaration(self, name: str, previous: p.Variable) -> str:
        if previous.kind == "uniform":
            return f"'{name}' is already declared as a parameter of the file"
        return f"'{name}' is already declared in this scope (line {self.line(previous.pos)})"

    def qualifiers(self, qualifiers: Sequence[s.Qualifier], what: str) -> bool:
        """True if ``const``; refuses the storage qualifiers a BRDF shader has no use for."""
        is_const = False
        for qualifier in qualifiers:
            if qualifier.name == "const":
                is_const = True
            elif qualifier.name == "uniform":
                raise self.error(
                    qualifier.pos,
                    "uniform declarations are not supported: declare the parameter in the file's parameters section",
                )
            elif qualifier.name == "in" and what == "parameter":
                continue
            elif qualifier.name in ("out", "inout") and what == "parameter":
                raise self.error(qualifier.pos, f"'{qualifier.name}' parameters are not supported")
            else:
                raise self.error(
                    qualifier.pos, f"'{qualifier.name}' is not allowed on a {what} in a BRDF shader"
                )
        return is_const

    def function(self, declaration: s.FunctionDeclaration) -> None:
        name = declaration.name
        if name in self.scopes[0]:
            raise self.error(declaration.pos, f"'{name}' is already declared as a variable")
        result = self.type_of(declaration.return_type)
        params: list[p.Variable] = []
        for index, param in enumerate(declaration.params):
            is_const = self.qualifiers(param.qualifiers, "parameter")
            param_type = self.type_of(param.type_name)
            if param_type == VOID:
                if len(declaration.params) == 1 and param.name is None:
                    break  # f(void)
                raise self.error(param.pos, "a parameter cannot be void")
            param_name = param.name if param.name is not None else f"<parameter {index + 1}>"
            if param.name is not None and any(v.name == param.name for v in params):
                raise self.error(param.pos, f"two parameters are named '{param.name}'")
            params.append(p.Variable(param_name, param_type, "parameter", is_const, param.pos))
        param_types = tuple(v.type for v in params)

        function = next((f for f in self.functions.get(name, []) if f.param_types == param_types), None)
        if function is not None:
            if function.result != result:
                raise self.error(
                    declaration.pos,
                    f"'{name}({_describe(param_types)})' was declared returning {function.result} (line {self.line(function.pos)})",
                )
            if function.body is not None and declaration.body is not None:
                raise self.error(
                    declaration.pos,
                    f"'{function.signature()}' is already defined (line {self.line(function.pos)})",
                )
        else:
            function = p.Function(name, result, params, declaration.pos)
            self.functions.setdefault(name, []).append(function)
        if declaration.body is None:
            return
        function.params = params
        function.pos = declaration.pos
        self.current = function
        self.scopes.append({v.name: v for v in params})
        body = self.block(declaration.body)
        self.scopes.pop()
        self.current = None
        if result != VOID and not _always_returns(body):
            raise self.error(
                declaration.pos, f"function '{name}' can reach its end without returning a value"
            )
        function.body = body
        self.defined.append(function)

    # ---- statements

    def block(self, block: s.Block) -> p.Block:
        self.scopes.append({})
        statements = tuple(self.statement(child) for child in block.statements)
        self.scopes.pop()
        return p.Block(statements)

    def statement(self, statement: s.Statement) -> p.Stmt:
        if isinstance(statement, s.Block):
            return self.block(statement)
        if isinstance(statement, s.Declaration):
            return self.local_declaration(statement)
        if isinstance(statement, s.ExpressionStatement):
            if statement.expression is None:
                return p.Block(())
            return p.Evaluate(self.expr(statement.expression))
        if isinstance(statement, s.If):
            condition = self.condition(statement.condition, "if")
            then = self.scoped(statement.then)
            otherwise = None if statement.otherwise is None else self.scoped(statement.otherwise)
            return p.If(condition, then, otherwise)
        if isinstance(statement, s.For):
            self.scopes.append({})
            init = self.statement(statement.init)
            condition = None if statement.condition is None else self.condition(statement.condition, "for")
            step = None if statement.step is None else self.expr(statement.step)
            body = self.loop_body(statement.body)
            self.scopes.pop()
            return p.Loop(init, condition, step, body, test_first=True)
        if isinstance(statement, s.While):
            condition = self.condition(statement.condition, "while")
            return p.Loop(None, condition, None, self.loop_body(statement.body), test_first=True)
        if isinstance(statement, s.DoWhile):
            body = self.loop_body(statement.body)
            return p.Loop(None, self.condition(statement.condition, "do-while"), None, body, test_first=False)
        if isinstance(statement, s.Return):
            return self.return_statement(statement)
        if isinstance(statement, s.Break | s.Continue):
            word = "break" if isinstance(statement, s.Break) else "continue"
            if self.loop_depth == 0:
                raise self.error(statement.pos, f"'{word}' outside a loop")
            return p.Break() if isinstance(statement, s.Break) else p.Continue()
        assert isinstance(statement, s.Discard)
        raise self.error(statement.pos, "'discard' has no meaning in a BRDF shader")

    def scoped(self, statement: s.Statement) -> p.Stmt:
        """A sub-statement (of if or a loop) is a scope of its own even without braces."""
        self.scopes.append({})
        result = self.statement(statement)
        self.scopes.pop()
        return result

    def loop_body(self, statement: s.Statement) -> p.Stmt:
        self.loop_depth += 1
        body = self.scoped(statement)
        self.loop_depth -= 1
        return body

    def condition(self, expression: s.Expression, keyword: str) -> p.Expr:
        value = self.expr(expression)
        if value.type != BOOL:
            raise self.error(expression.pos, f"the condition of '{keyword}' must be a bool, not {value.type}")
        return value

    def return_statement(self, statement: s.Return) -> p.Return:
        assert self.current is not None
        result = self.current.result
        if statement.value is None:
            if result != VOID:
                raise self.error(statement.pos, f"'{self.current.name}' must return a {result}")
            return p.Return(None)
        value = self.expr(statement.value)
        if result == VOID:
            raise self.error(statement.pos, f"'{self.current.name}' returns void: it cannot return a value")
        return p.Return(self.convert(value, result, statement.pos, f"returning from '{self.current.name}'"))

    def local_declaration(self, declaration: s.Declaration) -> p.Stmt:
        is_const = self.qualifiers(declaration.qualifiers, "local variable")
        var_type = self.type_of(declaration.type_name)
        if var_type == VOID:
            raise self.error(declaration.type_name.pos, "a variable cannot be void")
        statements: list[p.Stmt] = []
        scope = self.scopes[-1]
        for declarator in declaration.declarators:
            if declarator.name in scope:
                raise self.error(declarator.pos, self.redeclaration(declarator.name, scope[declarator.name]))
            initializer = None
            if declarator.initializer is not None:
                initializer = self.initializer(declarator, var_type, is_const)
            elif is_const:
                raise self.error(declarator.pos, f"const '{declarator.name}' needs an initializer")
            variable = p.Variable(declarator.name, var_type, "local", is_const, declarator.pos)
            scope[declarator.name] = variable
            statements.append(p.Declare(variable, initializer))
        return statements[0] if len(statements) == 1 else p.Block(tuple(statements))

    # ---- expressions

    def lookup(self, name: str) -> p.Variable | None:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope[name]
        return None

    def read(self, variable: p.Variable) -> None:
        if self.current is not None:
            self.current.reads.add(variable)
        else:
            self.global_reads.add(variable)

    def expr(self, e: s.Expression) -> p.Expr:
        method = getattr(self, f"expr_{type(e).__name__}")
        return method(e)

    def expr_FloatLiteral(self, e: s.FloatLiteral) -> p.Expr:
        return p.Constant(FLOAT, (e.value,))

    def expr_IntLiteral(self, e: s.IntLiteral) -> p.Expr:
        if e.value > _INT_MAX:
            raise self.error(e.pos, f"integer {e.value} does not fit in 32 bits")
        return p.Constant(INT, (e.value,))

    def expr_BoolLiteral(self, e: s.BoolLiteral) -> p.Expr:
        return p.Constant(BOOL, (e.value,))

    def expr_Name(self, e: s.Name) -> p.Expr:
        variable = self.lookup(e.name)
        if variable is None:
            if e.name in self.functions or e.name in BUILTINS:
                raise self.error(e.pos, f"'{e.name}' is a function: call it with arguments")
            raise self.error(e.pos, f"unknown identifier '{e.name}'")
        self.read(variable)
        return p.VariableRef(variable.type, variable)

    def expr_Sequence(self, e: s.Sequence) -> p.Expr:
        items = tuple(self.expr(item) for item in e.items)
        return p.Sequence(items[-1].type, items)

    def expr_Unary(self, e: s.Unary) -> p.Expr:
        if e.op in _RESERVED_OPERATORS:
            raise self.error(e.pos, f"operator '{e.op}' is reserved in GLSL 1.20")
        if e.op == "-" and isinstance(e.operand, s.IntLiteral):
            value = -e.operand.value
            if value < _INT_MIN:
                raise self.error(e.operand.pos, f"integer {value} does not fit in 32 bits")
            return p.Constant(INT, (value,))
        operand = self.value(self.expr(e.operand), e.pos)
        if e.op == "!":
            if operand.type != BOOL:
                raise self.error(e.pos, f"operator '!' needs a bool, not {operand.type}")
            return p.Unary(BOOL, "!", operand)
        if not operand.type.is_numeric:
            raise self.error(e.pos, f"operator '{e.op}' needs a number or a vector, not {operand.type}")
        return operand if e.op == "+" else p.Unary(operand.type, "-", operand)

    def expr_Binary(self, e: s.Binary) -> p.Expr:
        op = e.op
        if op in _RESERVED_OPERATORS:
            raise self.error(e.pos, f"operator '{op}' is reserved in GLSL 1.20")
        left = self.value(self.expr(e.left), e.pos)
        right = self.value(self.expr(e.right), e.pos)
        if op in ("&&", "||", "^^"):
            for side in (left, right):
                if side.type != BOOL:
                    raise self.error(e.pos, f"operator '{op}' needs bools, not {side.type}")
            return p.Logical(op, left, right)
        if op in ("+", "-", "*", "/"):
            result_type, left, right = self.arithmetic(op, left, right, e.pos)
            return p.Arithmetic(result_type, op, left, right)
        if op in ("<", ">", "<=", ">="):
            if not (
                left.type.is_numeric
                and left.type.is_scalar
                and right.type.is_numeric
                and right.type.is_scalar
            ):
                raise self.error(
                    e.pos, f"operator '{op}' compares scalar numbers, not {left.type} and {right.type}"
                )
            left, right = self.common(left, right, e.pos, f"operator '{op}'")
            return p.Compare(op, left, right)
        assert op in ("==", "!=")
        left, right = self.common(left, right, e.pos, f"operator '{op}'")
        return p.Compare(op, left, right)

    def arithmetic(
        self, op: str, left: p.Expr, right: p.Expr, pos: s.Position
    ) -> tuple[GlslType, p.Expr, p.Expr]:
        for side in (left, right):
            if not side.type.is_numeric:
                raise self.error(pos, f"operator '{op}' needs numbers or vectors, not {side.type}")
        if left.type == INT and right.type == INT:
            return INT, left, right
        left = self.convert(left, float_type(left.type.size), pos, f"operator '{op}'")
        right = self.convert(right, float_type(right.type.size), pos, f"operator '{op}'")
        if left.type.size != right.type.size and not (left.type.is_scalar or right.type.is_scalar):
            raise self.error(pos, f"operator '{op}' cannot combine {left.type} and {right.type}")
        return (left.type if left.type.size >= right.type.size else right.type), left, right

    def common(self, a: p.Expr, b: p.Expr, pos: s.Position, what: str) -> tuple[p.Expr, p.Expr]:
        """``a`` and ``b`` converted to one type (int to float), or an error."""
        if a.type == b.type:
            return a, b
        if implicitly_converts(a.type, b.type):
            return self.convert(a, b.type, pos, what), b
        if implicitly_converts(b.type, a.type):
            return a, self.convert(b, a.type, pos, what)
        raise self.error(pos, f"{what}: {a.type} and {b.type} do not match")

    def convert(self, value: p.Expr, target: GlslType, pos: s.Position, what: str) -> p.Expr:
        if value.type == target:
            return value
        if value.type == VOID:
            raise self.error(pos, f"{what}: the expression has no value (void)")
        if not implicitly_converts(value.type, target):
            raise self.error(pos, f"{what}: cannot convert {value.type} to {target}")
        if isinstance(value, p.Constant):
            return p.Constant(target, tuple(float(v) for v in value.values))
        return p.Convert(target, value)

    def value(self, value: p.Expr, pos: s.Position) -> p.Expr:
        if value.type == VOID:
            raise self.error(pos, "a void function call has no value to use here")
        return value

    def expr_Conditional(self, e: s.Conditional) -> p.Expr:
        condition = self.expr(e.condition)
        if condition.type != BOOL:
            raise self.error(e.pos, f"the condition of '?:' must be a bool, not {condition.type}")
        if_true = self.value(self.expr(e.if_true), e.pos)
        if_false = self.value(self.expr(e.if_false), e.pos)
        if_true, if_false = self.common(if_true, if_false, e.pos, "the two branches of '?:'")
        return p.Select(if_true.type, condition, if_true, if_false)

    def expr_Field(self, e: s.Field) -> p.Expr:
        operand = self.value(self.expr(e.operand), e.pos)
        return self.swizzle(operand, e.name, e.pos)

    def swizzle(self, operand: p.Expr, name: str, pos: s.Position) -> p.Swizzle:
        if not operand.type.is_vector:
            raise self.error(pos, f"a {operand.type} has no components: '.{name}' needs a vector")
        letters = next((set_ for set_ in _SWIZZLE_SETS if set_.find(name[0]) >= 0), None)
        if letters is None or len(name) > 4 or any(c not in letters for c in name):
            raise self.error(
                pos, f"'.{name}' is not a swizzle (use up to 4 of xyzw, rgba or stpq, from one set)"
            )
        components = tuple(letters.index(c) for c in name)
        if max(components) >= operand.type.size:
            raise self.error(
                pos, f"'.{name}' reaches past the {operand.type.size} components of a {operand.type}"
            )
        return p.Swizzle(float_type(len(components)), operand, components)

    def expr_Index(self, e: s.Index) -> p.Expr:
        operand = self.value(self.expr(e.operand), e.pos)
        if not operand.type.is_vector:
            raise self.error(e.pos, f"a {operand.type} cannot be indexed: '[]' needs a vector")
        index = self.expr(e.index)
        if index.type != INT:
            raise self.error(e.index.pos, f"an index must be an int, not {index.type}")
        if isinstance(index, p.Constant) and not 0 <= int(index.values[0]) < operand.type.size:
            raise self.error(
                e.index.pos,
                f"index {index.values[0]} is outside the {operand.type.size} components of a {operand.type}",
            )
        return p.IndexOf(FLOAT, operand, index)

    # ---- assignments

    def target(self, e: s.Expression, op: str) -> p.Expr:
        """The checked left side of an assignment or ``++``/``--``; it is read too unless ``op`` is ``=``."""
        if isinstance(e, s.Name):
            variable = self.lookup(e.name)
            if variable is None:
                raise self.error(e.pos, f"unknown identifier '{e.name}'")
            if variable.kind == "uniform":
                raise self.error(
                    e.pos, f"cannot assign to '{e.name}': the file's parameters are read-only uniforms"
                )
            if variable.is_const:
                raise self.error(e.pos, f"cannot assign to const '{e.name}'")
            if op != "=":
                self.read(variable)
            return p.VariableRef(variable.type, variable)
        if isinstance(e, s.Field):
            operand = self.target(e.operand, op)
            swizzle = self.swizzle(operand, e.name, e.pos)
            if len(set(swizzle.components)) != len(swizzle.components):
                raise self.error(e.pos, f"cannot assign to '.{e.name}': it names a component twice")
            return swizzle
        if isinstance(e, s.Index):
            operand = self.target(e.operand, op)
            if not operand.type.is_vector:
                raise self.error(e.pos, f"a {operand.type} cannot be indexed: '[]' needs a vector")
            index = self.expr(e.index)
            if index.type != INT:
                raise self.error(e.index.pos, f"an index must be an int, not {index.type}")
            if isinstance(index, p.Constant) and not 0 <= int(index.values[0]) < operand.type.size:
                raise self.error(
                    e.index.pos,
                    f"index {index.values[0]} is outside the {operand.type.size} components of a {operand.type}",
                )
            return p.IndexOf(FLOAT, operand, index)
        raise self.error(e.pos, "this expression cannot be assigned to")

    def expr_Assignment(self, e: s.Assignment) -> p.Expr:
        if e.op != "=" and e.op not in _COMPOUND_OPERATORS:
            raise self.error(e.pos, f"operator '{e.op}' is reserved in GLSL 1.20")
        target = self.target(e.target, e.op)
        value = self.value(self.expr(e.value), e.pos)
        if e.op == "=":
            return p.Assign(target.type, None, target, self.convert(value, target.type, e.pos, "assignment"))
        op = _COMPOUND_OPERATORS[e.op]
        result_type, _, converted = self.arithmetic(op, target, value, e.pos)
        if result_type != target.type:
            raise self.error(e.pos, f"'{e.op}' would turn the {target.type} on its left into a {result_type}")
        return p.Assign(target.type, op, target, converted)

    def expr_Update(self, e: s.Update) -> p.Expr:
        target = self.target(e.target, e.op)
        if not target.type.is_numeric:
            raise self.error(e.pos, f"operator '{e.op}' needs a number or a vector, not {target.type}")
        return p.Update(target.type, e.op[0], e.prefix, target)

    # ---- calls

    def expr_Call(self, e: s.Call) -> p.Expr:
        args = tuple(self.value(self.expr(a), a.pos) for a in e.args)
        if e.is_constructor:
            return self.constructor(e, args)
        variable = self.lookup(e.callee)
        if variable is not None and variable.kind in ("local", "parameter"):
            raise self.error(
                e.pos, f"'{e.callee}' is a variable here (line {self.line(variable.pos)}), not a function"
            )
        arg_types = tuple(a.type for a in args)
        user = self.functions.get(e.callee)
        if user:
            function = self.resolve(e.callee, user, arg_types, e.pos)
            assert isinstance(function, p.Function)
            if self.current is not None:
                self.current.callees.setdefault(function, e.pos)
            self.first_calls.setdefault(function, e.pos)
            converted = self.arguments(args, function.param_types, e)
            return p.CallFunction(function.result, function, converted)
        builtin = BUILTINS.get(e.callee)
        if builtin is None:
            raise self.error(e.pos, f"unknown function '{e.callee}'")
        overload = self.resolve(e.callee, builtin, arg_types, e.pos)
        assert isinstance(overload, Overload)
        return p.CallBuiltin(overload.result, overload, self.arguments(args, overload.param_types, e))

    def arguments(self, args: Sequence[p.Expr], types: Sequence[GlslType], e: s.Call) -> tuple[p.Expr, ...]:
        return tuple(
            self.convert(a, t, e.pos, f"argument {i + 1} of '{e.callee}'")
            for i, (a, t) in enumerate(zip(args, types, strict=True))
        )

    def resolve(
        self,
        name: str,
        candidates: Sequence[p.Function | Overload],
        arg_types: tuple[GlslType, ...],
        pos: s.Position,
    ) -> p.Function | Overload:
        same_arity = [c for c in candidates if len(c.param_types) == len(arg_types)]
        if not same_arity:
            counts = sorted({len(c.param_types) for c in candidates})
            expected = " or ".join(str(n) for n in counts)
            plural = "" if counts == [1] else "s"
            raise self.error(pos, f"'{name}' takes {expected} argument{plural}, not {len(arg_types)}")
        for candidate in same_arity:
            if candidate.param_types == arg_types:
                return candidate
        viable = [
            c
            for c in same_arity
            if all(implicitly_converts(a, t) for a, t in zip(arg_types, c.param_types, strict=True))
        ]
        if len(viable) > 1:
            costs = [sum(a != t for a, t in zip(arg_types, c.param_types, strict=True)) for c in viable]
            best = min(costs)
            viable = [c for c, cost in zip(viable, costs, strict=True) if cost == best]
        if len(viable) == 1:
            return viable[0]
        call = f"{name}({_describe(arg_types)})"
        if viable:
            raise self.error(
                pos, f"the call {call} is ambiguous between {' and '.join(c.signature() for c in viable)}"
            )
        listed = "; ".join(c.signature() for c in same_arity[:6]) + ("; ..." if len(same_arity) > 6 else "")
        raise self.error(pos, f"no overload of '{name}' matches {call} (candidates: {listed})")

    def constructor(self, e: s.Call, args: tuple[p.Expr, ...]) -> p.Expr:
        target = TYPES_BY_NAME[e.callee]
        if target == VOID:
            raise self.error(e.pos, "void is not a constructor")
        if not args:
            raise self.error(e.pos, f"{target}() needs at least one argument")
        if target.is_scalar:
            if len(args) > 1:
                raise self.error(e.pos, f"{target}() takes one argument, not {len(args)}")
            (arg,) = args
            if arg.type == target:
                return arg
            if isinstance(arg, p.Constant) and arg.type.is_scalar:
                return p.Constant(target, (_convert_constant(arg.values[0], target),))
            return p.Construct(target, args)
        if len(args) == 1 and args[0].type.is_scalar:
            return p.Construct(target, args)
        total = 0
        for index, arg in enumerate(args):
            if total >= target.size:
                raise self.error(e.pos, f"too many arguments to {target}(): argument {index + 1} is not used")
            total += arg.type.size
        if total < target.size:
            raise self.error(e.pos, f"{target}() needs {target.size} components, the arguments give {total}")
        return p.Construct(target, args)


def _convert_constant(value: float | int | bool, target: GlslType) -> float | int | bool:
    """A scalar constructor on a constant, as the generated code would compute it (int() truncates toward
    zero and saturates)."""
    if target == FLOAT:
        return float(value)
    if target == BOOL:
        return bool(value)
    return min(max(int(value), _INT_MIN), _INT_MAX)
