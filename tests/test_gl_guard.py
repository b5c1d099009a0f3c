"""The GL guard of tests/conftest.py, which every test runs under, fails what it is there to
catch: a GL error left pending, a context left unreleased, GL started by a test not marked
``gl``; and it resets the state a test leaves (run on a planted test file, with the suite's
own conftest)."""

import ctypes
from pathlib import Path

import pytest

pytest_plugins = ["pytester"]

CONFTEST = Path(__file__).with_name("conftest.py")
PLANTED = """
import ctypes
import moderngl
import pytest
from genie_gl.render import create_context

@pytest.mark.gl
def test_leaks_a_context():
    create_context("egl")

def test_starts_gl_unmarked():
    create_context("egl").release()

@pytest.mark.gl
def test_leaves_a_gl_error(gl):
    bind = gl.gl_function("glBindTexture", None, ctypes.c_uint, ctypes.c_uint)
    with gl.current():
        bind(0xFFFF, 0)          # not a texture target: GL_INVALID_ENUM

@pytest.mark.gl
def test_leaves_state(gl):
    with gl.current():
        gl.ctx.enable(moderngl.CULL_FACE)
        gl.ctx.front_face = "cw"

@pytest.mark.gl
def test_finds_the_state_reset(gl):
    get = gl.gl_function("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
    is_on = gl.gl_function("glIsEnabled", ctypes.c_ubyte, ctypes.c_uint)
    value = ctypes.c_int()
    with gl.current():
        get(0x0B46, ctypes.byref(value))      # GL_FRONT_FACE
        assert value.value == 0x0901 and not is_on(0x0B44)   # GL_CCW, GL_CULL_FACE off

def test_without_gl():
    assert 1 + 1 == 2
"""


@pytest.mark.gl
def test_the_guard_fails_errors_leaks_and_unmarked_gl_and_resets_state(pytester):
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makepyfile(test_planted=PLANTED)
    result = pytester.runpytest_subprocess(
        "-p", "no:cacheprovider", "-p", "no:randomly", "-n", "0", "-q"
    )
    result.assert_outcomes(passed=6, errors=3)  # three bodies pass, their teardown fails
    out = result.stdout.str()
    assert "left 1 GL context(s) unreleased" in out
    assert "the test started GL: mark it gl" in out
    assert "GL errors after the test: [('egl', 'GL_INVALID_ENUM')]" in out


@pytest.mark.gl
def test_a_context_reports_and_clears_its_error_and_resets(gl):
    bind = gl.gl_function("glBindTexture", None, ctypes.c_uint, ctypes.c_uint)
    with gl.current():
        bind(0xFFFF, 0)
    assert gl.error() == "GL_INVALID_ENUM" and gl.error() == "GL_NO_ERROR"  # read once, then clear
    get = gl.gl_function("glGetIntegerv", None, ctypes.c_uint, ctypes.POINTER(ctypes.c_int))
    value = ctypes.c_int()
    with gl.current():
        gl.ctx.depth_func = ">"
        get(0x0B74, ctypes.byref(value))  # GL_DEPTH_FUNC
    assert value.value == 0x0204  # GL_GREATER
    gl.reset()
    with gl.current():
        get(0x0B74, ctypes.byref(value))
    assert value.value == 0x0201  # GL_LESS
