"""GLSL source to :mod:`core.glsl.syntax` tree, with lark's LALR(1) parser over ``glsl.lark``.

The tree's positions count in the shader text; errors found here are reported in the ``.brdf`` file's lines
(shader line 1 is file line ``first_line``). Before lark sees the text, a comment-aware scan refuses
preprocessor directives other than ``#version`` and ``#pragma`` (the shader is compiled without a
preprocessor) and comments that are never closed.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import resources

import lark
from lark import Lark, Token, Transformer

from core.cache import default_folder
from core.glsl import syntax as s
from core.glsl.errors import ShaderError
from core.glsl.keywords import reserved_name_problem

HARMLESS_DIRECTIVES = ("version", "pragma")

# How a syntax error names what was expected, for the terminals that are not plain strings.
_TERMINAL_WORDS = {
    "IDENTIFIER": "a name",
    "FLOATCONSTANT": "a number",
    "INTCONSTANT": "a number",
    "$END": "the end of the shader",
}


class _BadToken(Exception):
    """Raised while parsing (a reserved word, a malformed number); parse_shader turns it into a ShaderError
    with the file's position."""

    def __init__(self, token: Token, problem: str) -> None:
        super().__init__(problem)
        self.token = token
        self.problem = problem


def _check_identifier(token: Token) -> Token:
    problem = reserved_name_problem(str(token))
    if problem is not None:
        raise _BadToken(token, f"{problem} and cannot be used here")
    return token


@cache
def _lark() -> Lark:
    """The parser, built once per process. Building the LALR tables takes a noticeable part of a second, so
    lark keeps them in the user's cache folder (it rebuilds them when the grammar or lark changes)."""
    grammar = resources.files("core.glsl").joinpath("glsl.lark").read_text(encoding="utf-8")
    folder = default_folder()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        cache_file: str | bool = str(folder / "glsl-grammar.lark-cache")
    except OSError:
        cache_file = False
    return Lark(
        grammar,
        parser="lalr",
        lexer="basic",
        maybe_placeholders=True,
        transformer=_ToSyntax(),  # applied while parsing: no parse tree is built
        lexer_callbacks={"IDENTIFIER": _check_identifier},
        cache=cache_file,
    )


def parse_shader(source: str, path: str, first_line: int = 1) -> s.TranslationUnit:
    """Parse GLSL ``source``, the shader block of ``path`` whose first line is line ``first_line`` of the file.
    The tree's positions count in ``source``; errors are reported in the file's lines.

    Raises
    ------
    ShaderError
        A syntax error, a reserved word, a preprocessor directive or an unclosed comment, at its place in the file.
    """
    line_offset = first_line - 1
    _check_directives(source, path, line_offset)
    parser = _lark()
    try:
        unit = parser.parse(source)
    except _BadToken as error:
        raise ShaderError(path, error.token.line + line_offset, error.token.column, error.problem) from None
    except lark.exceptions.UnexpectedInput as error:
        message = _syntax_message(error, parser)
        missing = _missing_semicolon_line(error, source)
        if missing is not None:
            message += f" (is a ';' missing at the end of line {missing + line_offset}?)"
        raise ShaderError(path, error.line + line_offset, error.column, message) from None
    assert isinstance(unit, s.TranslationUnit)
    return unit


def _syntax_message(error: lark.exceptions.UnexpectedInput, parser: Lark) -> str:
    if isinstance(error, lark.exceptions.UnexpectedCharacters):
        return f"syntax error: unexpected character '{error.char}'"
    if isinstance(error, lark.exceptions.UnexpectedEOF):
        return "syntax error: the shader ends too early"
    assert isinstance(error, lark.exceptions.UnexpectedToken)
    token = error.token
    if token.type == "$END":
        hint = " (is a '}' missing?)" if "RBRACE" in error.expected else ""
        return f"syntax error: the shader ends too early{hint}"
    found = f"'{token}'"
    strings = {
        t.name: t.pattern.value for t in parser.terminals if isinstance(t.pattern, lark.lexer.PatternStr)
    }
    expected = sorted({_TERMINAL_WORDS.get(name, f"'{strings.get(name, name)}'") for name in error.expected})
    if 0 < len(expected) <= 6:
        return f"syntax error: unexpected {found}; expected {' or '.join(expected)}"
    return f"syntax error: unexpected {found}"


def _missing_semicolon_line(error: lark.exceptions.UnexpectedInput, source: str) -> int | None:
    """The shader line of the code before an unexpected token that a ';' could have ended, if it is on an
    earlier line than the token (the usual forgotten semicolon)."""
    if not isinstance(error, lark.exceptions.UnexpectedToken) or "SEMICOLON" not in error.expected:
        return None
    start = error.token.start_pos
    if error.token.type == "$END" or start is None:
        return None
    code = _COMMENT_OR_DIRECTIVE.sub(lambda m: re.sub(r"[^\n]", " ", m.group()), source[:start]).rstrip()
    if not code:
        return None
    line = code.count("\n") + 1
    return line if line < error.line else None


_COMMENT_OR_DIRECTIVE = re.compile(r"//[^\n]*|/\*[\s\S]*?\*/|/\*|#[^\n]*")


def _check_directives(source: str, path: str, line_offset: int) -> None:
    for match in _COMMENT_OR_DIRECTIVE.finditer(source):
        text = match.group()
        if not text.startswith("#") and text != "/*":
            continue
        line = source.count("\n", 0, match.start()) + 1
        line_start = source.rfind("\n", 0, match.start()) + 1
        column = match.start() - line_start + 1
        if text == "/*":
            raise ShaderError(path, line + line_offset, column, "this comment is never closed (missing '*/')")
        if source[line_start : match.start()].strip():
            raise ShaderError(
                path, line + line_offset, column, "'#' may only begin a preprocessor directive line"
            )
        words = text[1:].split()
        if words and words[0] not in HARMLESS_DIRECTIVES:
            raise ShaderError(
                path,
                line + line_offset,
                column,
                f"preprocessor directive '#{words[0]}' is not supported (only #version and #pragma are accepted)",
            )


def _unpack(children: list) -> list:
    return [child for child in children if child is not None]


def _position(token: Token) -> s.Position:
    return s.Position(token.line, token.column)


class _ToSyntax(Transformer):
    """Builds the :mod:`core.glsl.syntax` nodes as lark reduces each grammar rule or alias (one method each);
    positions come from the tokens."""

    # ---- declarations
    def start(self, children: list) -> s.TranslationUnit:
        return s.TranslationUnit(tuple(children))

    def type_specifier(self, children: list) -> s.TypeName:
        (token,) = children
        return s.TypeName(_position(token), str(token))

    def qualifier(self, children: list) -> s.Qualifier:
        (token,) = children
        return s.Qualifier(_position(token), str(token))

    def init_declarator(self, children: list) -> s.Declarator:
        name, initializer = children
        return s.Declarator(_position(name), str(name), initializer)

    def declaration(self, children: list) -> s.Declaration:
        qualifiers = tuple(c for c in children if isinstance(c, s.Qualifier))
        (type_name,) = (c for c in children if isinstance(c, s.TypeName))
        declarators = tuple(c for c in children if isinstance(c, s.Declarator))
        pos = qualifiers[0].pos if qualifiers else type_name.pos
        return s.Declaration(pos, qualifiers, type_name, declarators)

    def parameter(self, children: list) -> s.Parameter:
        *qualifiers, type_name, name = children
        pos = qualifiers[0].pos if qualifiers else type_name.pos
        return s.Parameter(pos, tuple(qualifiers), type_name, None if name is None else str(name))

    def function_header(self, children: list) -> s.FunctionDeclaration:
        return_type, name, *params = children
        return s.FunctionDeclaration(_position(name), return_type, str(name), tuple(_unpack(params)), None)

    def function_definition(self, children: list) -> s.FunctionDeclaration:
        header, body = children
        return s.FunctionDeclaration(header.pos, header.return_type, header.name, header.params, body)

    def function_prototype(self, children: list) -> s.FunctionDeclaration:
        (header,) = children
        return header

    # ---- statements
    def compound_statement(self, children: list) -> s.Block:
        return s.Block(children[0].pos if children else s.Position(0, 0), tuple(children))

    def expression_statement(self, children: list) -> s.ExpressionStatement:
        (expression,) = children
        return s.ExpressionStatement(s.Position(0, 0) if expression is None else expression.pos, expression)

    def if_statement(self, children: list) -> s.If:
        keyword, condition, then, _else, otherwise = children
        return s.If(_position(keyword), condition, then, otherwise)

    def for_statement(self, children: list) -> s.For:
        keyword, init, condition, step, body = children
        return s.For(_position(keyword), init, condition, step, body)

    def while_statement(self, children: list) -> s.While:
        keyword, condition, body = children
        return s.While(_position(keyword), condition, body)

    def do_statement(self, children: list) -> s.DoWhile:
        keyword, body, _while, condition = children
        return s.DoWhile(_position(keyword), body, condition)

    def return_statement(self, children: list) -> s.Return:
        keyword, value = children
        return s.Return(_position(keyword), value)

    def break_statement(self, children: list) -> s.Break:
        return s.Break(_position(children[0]))

    def continue_statement(self, children: list) -> s.Continue:
        return s.Continue(_position(children[0]))

    def discard_statement(self, children: list) -> s.Discard:
        return s.Discard(_position(children[0]))

    # ---- expressions
    def sequence(self, children: list) -> s.Sequence:
        left, comma, right = children
        items = left.items if isinstance(left, s.Sequence) else (left,)
        return s.Sequence(_position(comma), (*items, right))

    def assignment_operator(self, children: list) -> Token:
        (token,) = children
        return token

    def assignment(self, children: list) -> s.Assignment:
        target, op, value = children
        return s.Assignment(_position(op), str(op), target, value)

    def conditional(self, children: list) -> s.Conditional:
        condition, question, if_true, if_false = children
        return s.Conditional(_position(question), condition, if_true, if_false)

    def binary(self, children: list) -> s.Binary:
        left, op, right = children
        return s.Binary(_position(op), str(op), left, right)

    def unary(self, children: list) -> s.Unary:
        op, operand = children
        return s.Unary(_position(op), str(op), operand)

    def prefix_update(self, children: list) -> s.Update:
        op, target = children
        return s.Update(_position(op), str(op), True, target)

    def postfix_update(self, children: list) -> s.Update:
        target, op = children
        return s.Update(_position(op), str(op), False, target)

    def index(self, children: list) -> s.Index:
        operand, index = children
        return s.Index(operand.pos, operand, index)

    def field(self, children: list) -> s.Field:
        operand, name = children
        return s.Field(_position(name), operand, str(name))

    def arguments(self, children: list) -> tuple[s.Expression, ...]:
        return tuple(children)

    def call(self, children: list) -> s.Call:
        name, args = children
        return s.Call(_position(name), str(name), args or (), False)

    def constructor(self, children: list) -> s.Call:
        type_name, args = children
        return s.Call(type_name.pos, type_name.name, args or (), True)

    def name(self, children: list) -> s.Name:
        (token,) = children
        return s.Name(_position(token), str(token))

    def float_constant(self, children: list) -> s.FloatLiteral:
        (token,) = children
        return s.FloatLiteral(_position(token), float(str(token).rstrip("fF")))

    def int_constant(self, children: list) -> s.IntLiteral:
        (token,) = children
        value = _int_value(str(token))
        if value is None:
            raise _BadToken(token, f"'{token}' is not an integer (octal digits are 0-7)")
        if value > 2**31:  # 2**31 itself may follow a unary minus
            raise _BadToken(token, f"integer {token} does not fit in 32 bits")
        return s.IntLiteral(_position(token), value)

    def bool_constant(self, children: list) -> s.BoolLiteral:
        (token,) = children
        return s.BoolLiteral(_position(token), str(token) == "true")


def _int_value(text: str) -> int | None:
    """C's integer literals: ``0x1F`` hexadecimal, ``017`` octal, else decimal; None if malformed (``08``)."""
    if text[:2] in ("0x", "0X"):
        return int(text, 16)
    if len(text) > 1 and text[0] == "0":
        try:
            return int(text, 8)
        except ValueError:
            return None
    return int(text)
