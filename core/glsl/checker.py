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

Every error is a :class:`ShaderError` at the offending token, in the ``.brdf`` file's lines. This module checks
declarations, functions and statements; :mod:`core.glsl.expressions` types the expressions.
"""

from __future__ import annotations

from collections.abc import Sequence

from core.glsl import program as p
from core.glsl import syntax as s
from core.glsl.brdf_file import ShaderParam
from core.glsl.expressions import ExpressionChecker, describe_types
from core.glsl.types import (
    BOOL,
    TYPES_BY_NAME,
    VEC3,
    VOID,
    GlslType,
)

BRDF_SIGNATURE = "vec3 BRDF(vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y)"


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
    return Checker(path, params, shader_line).run(unit)


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


class Checker(ExpressionChecker):
    """Binds and checks a translation unit: its declarations, functions and statements."""

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
                    f"'{name}({describe_types(param_types)})' was declared returning {function.result} (line {self.line(function.pos)})",
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
