"""GLSL source to :mod:`core.glsl.syntax` tree, with lark's LALR(1) parser over ``glsl.lark``.

Positions are moved into the ``.brdf`` file's numbering (shader line 1 is file line ``first_line``). Before
lark sees the text, a comment-aware scan refuses preprocessor directives other than ``#version`` and
``#pragma`` (the shader is compiled without a preprocessor) and comments that are never closed.
"""

from __future__ import annotations

import re
from functools import cache
from importlib import resources

import lark
from lark import Lark, Token, Transformer, v_args

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


class _ReservedWord(Exception):
    """Raised by the lexer on an identifier GLSL reserves; turned into a ShaderError with the file's position."""

    def __init__(self, token: Token, problem: str) -> None:
        super().__init__(problem)
        self.token = token
        self.problem = problem


def _check_identifier(token: Token) -> Token:
    problem = reserved_name_problem(str(token))
    if problem is not None:
        raise _ReservedWord(token, problem)
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
        propagate_positions=True,
        maybe_placeholders=True,
        lexer_callbacks={"IDENTIFIER": _check_identifier},
        cache=cache_file,
    )


def parse_shader(source: str, path: str, first_line: int = 1) -> s.TranslationUnit:
    """Parse GLSL ``source`` (the shader block of ``path``, whose first line is line ``first_line`` of the file).

    Raises
    ------
    ShaderError
        A syntax error, a reserved word, a preprocessor directive or an unclosed comment, at its place in the file.
    """
    line_offset = first_line - 1
    _check_directives(source, path, line_offset)
    parser = _lark()
    try:
        tree = parser.parse(source)
    except _ReservedWord as error:
        raise ShaderError(
            path,
            error.token.line + line_offset,
            error.token.column,
            f"{error.problem} and cannot be used here",
        ) from None
    except lark.exceptions.UnexpectedInput as error:
        message = _syntax_message(error, parser)
        missing = _missing_semicolon_line(error, source)
        if missing is not None:
            message += f" (is a ';' missing at the end of line {missing + line_offset}?)"
        raise ShaderError(path, error.line + line_offset, error.column, message) from None
    try:
        return _ToSyntax(path, line_offset).transform(tree)
    except lark.exceptions.VisitError as error:
        if isinstance(error.orig_exc, ShaderError):
            raise error.orig_exc from None
        raise


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


@v_args(meta=True)
class _ToSyntax(Transformer):
    """lark's parse tree to :mod:`core.glsl.syntax` nodes (one method per grammar rule or alias)."""

    def __init__(self, path: str, line_offset: int) -> None:
        super().__init__()
        self._path = path
        self._offset = line_offset

    def _at(self, meta_or_token) -> s.Position:
        if isinstance(meta_or_token, Token):
            return s.Position(meta_or_token.line + self._offset, meta_or_token.column)
        if getattr(meta_or_token, "empty", True):
            return s.Position(0, 0)
        return s.Position(meta_or_token.line + self._offset, meta_or_token.column)

    # ---- declarations
    def start(self, meta, children):
        return s.TranslationUnit(tuple(children))

    def type_specifier(self, meta, children):
        (token,) = children
        return s.TypeName(self._at(token), str(token))

    def qualifier(self, meta, children):
        (token,) = children
        return s.Qualifier(self._at(token), str(token))

    def init_declarator(self, meta, children):
        name, initializer = children
        return s.Declarator(self._at(name), str(name), initializer)

    def declaration(self, meta, children):
        qualifiers = tuple(c for c in children if isinstance(c, s.Qualifier))
        (type_name,) = (c for c in children if isinstance(c, s.TypeName))
        declarators = tuple(c for c in children if isinstance(c, s.Declarator))
        return s.Declaration(self._at(meta), qualifiers, type_name, declarators)

    def parameter(self, meta, children):
        *qualifiers, type_name, name = children
        return s.Parameter(self._at(meta), tuple(qualifiers), type_name, None if name is None else str(name))

    def function_header(self, meta, children):
        return_type, name, *params = children
        return s.FunctionDeclaration(self._at(name), return_type, str(name), tuple(_unpack(params)), None)

    def function_definition(self, meta, children):
        header, body = children
        return s.FunctionDeclaration(header.pos, header.return_type, header.name, header.params, body)

    def function_prototype(self, meta, children):
        (header,) = children
        return header

    # ---- statements
    def compound_statement(self, meta, children):
        return s.Block(self._at(meta), tuple(children))

    def expression_statement(self, meta, children):
        (expression,) = children
        return s.ExpressionStatement(self._at(meta), expression)

    def if_statement(self, meta, children):
        keyword, condition, then, _else, otherwise = children
        return s.If(self._at(keyword), condition, then, otherwise)

    def for_statement(self, meta, children):
        keyword, init, condition, step, body = children
        return s.For(self._at(keyword), init, condition, step, body)

    def while_statement(self, meta, children):
        keyword, condition, body = children
        return s.While(self._at(keyword), condition, body)

    def do_statement(self, meta, children):
        keyword, body, _while, condition = children
        return s.DoWhile(self._at(keyword), body, condition)

    def return_statement(self, meta, children):
        keyword, value = children
        return s.Return(self._at(keyword), value)

    def break_statement(self, meta, children):
        return s.Break(self._at(children[0]))

    def continue_statement(self, meta, children):
        return s.Continue(self._at(children[0]))

    def discard_statement(self, meta, children):
        return s.Discard(self._at(children[0]))

    # ---- expressions
    def sequence(self, meta, children):
        left, comma, right = children
        items = left.items if isinstance(left, s.Sequence) else (left,)
        return s.Sequence(self._at(comma), (*items, right))

    def assignment_operator(self, meta, children):
        (token,) = children
        return token

    def assignment(self, meta, children):
        target, op, value = children
        return s.Assignment(self._at(op), str(op), target, value)

    def conditional(self, meta, children):
        condition, question, if_true, if_false = children
        return s.Conditional(self._at(question), condition, if_true, if_false)

    def binary(self, meta, children):
        left, op, right = children
        return s.Binary(self._at(op), str(op), left, right)

    def unary(self, meta, children):
        op, operand = children
        return s.Unary(self._at(op), str(op), operand)

    def prefix_update(self, meta, children):
        op, target = children
        return s.Update(self._at(op), str(op), True, target)

    def postfix_update(self, meta, children):
        target, op = children
        return s.Update(self._at(op), str(op), False, target)

    def index(self, meta, children):
        operand, index = children
        return s.Index(self._at(meta), operand, index)

    def field(self, meta, children):
        operand, name = children
        return s.Field(self._at(name), operand, str(name))

    def arguments(self, meta, children):
        return tuple(children)

    def call(self, meta, children):
        name, args = children
        return s.Call(self._at(name), str(name), args or (), False)

    def constructor(self, meta, children):
        type_name, args = children
        return s.Call(type_name.pos, type_name.name, args or (), True)

    def name(self, meta, children):
        (token,) = children
        return s.Name(self._at(token), str(token))

    def float_constant(self, meta, children):
        (token,) = children
        return s.FloatLiteral(self._at(token), float(str(token).rstrip("fF")))

    def int_constant(self, meta, children):
        (token,) = children
        pos = self._at(token)
        value = _int_value(str(token))
        if value is None:
            raise ShaderError(
                self._path, pos.line, pos.column, f"'{token}' is not an integer (octal digits are 0-7)"
            )
        if value > 2**31:  # 2**31 itself may follow a unary minus
            raise ShaderError(self._path, pos.line, pos.column, f"integer {token} does not fit in 32 bits")
        return s.IntLiteral(pos, value)

    def bool_constant(self, meta, children):
        (token,) = children
        return s.BoolLiteral(self._at(token), str(token) == "true")


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
