"""The line a command prints while numba compiles (:mod:`app.commands._compile_notice`): once, and only then."""

from __future__ import annotations

import io

from numba import njit

from app.commands._compile_notice import START, CompileNotice


def _fresh_kernel():
    """A jitted function no process has compiled yet (defined anew, not cached)."""

    @njit(cache=False)
    def add_one(x):
        return x + 1.0

    @njit(cache=False)
    def twice_plus_one(x):
        return add_one(x) * 2.0  # its callee compiles inside it: one outermost compile

    return twice_plus_one


def test_a_command_that_compiles_says_so_once_and_how_long_it_took():
    stream = io.StringIO()
    notice = CompileNotice("eval", stream)
    notice.install()
    try:
        kernel = _fresh_kernel()
        assert kernel(1.0) == 4.0
        kernel(2.0)  # compiled already: nothing more
        _fresh_kernel()(3.0)  # another new one: counted, not announced again
    finally:
        notice.close()
    lines = stream.getvalue().splitlines()
    assert lines[0] == f"brdf-studio eval: {START}"
    assert len(lines) == 2 and lines[1].startswith("brdf-studio eval: compiled 2 kernels in ")
    assert notice.compiles == 2 and notice.seconds > 0.0


def test_a_command_whose_kernels_are_compiled_already_prints_nothing():
    kernel = _fresh_kernel()
    kernel(1.0)
    stream = io.StringIO()
    notice = CompileNotice("render", stream)
    notice.install()
    kernel(5.0)
    notice.close()
    assert stream.getvalue() == "" and notice.compiles == 0
    _fresh_kernel()(1.0)  # after close it no longer listens
    assert stream.getvalue() == ""
