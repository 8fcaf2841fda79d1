"""Fixtures shared by the Monte Carlo tests of tests/profiles."""

import pytest


@pytest.fixture(params=["numba", "gl"])
def mc_backend(request):
    """Each Monte Carlo engine: numba, and the GLSL one where an OpenGL 4.3 context exists (llvmpipe in CI)."""
    if request.param == "gl":
        from ssskit.profiles.montecarlo import engine_gl

        ok, why = engine_gl.available()
        if not ok:
            pytest.skip(f"gl engine not available: {why}")
    return request.param
