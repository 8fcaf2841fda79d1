"""What only the ``gl`` backend has: its layouts, its generated shader source, its frames that stay on the
device, its messages when EGL or moderngl is missing, and readable shader compile errors. The pass's
physics and parity run on ``gl`` through the ``backend`` fixture in test_separable.py."""

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from ssskit.backends import backend_status, build_separable_plan
from ssskit.backends.numpy_backend import NumpyBackend
from ssskit.errors import BackendError
from tests.backends.test_separable import _taps, _three_materials
from tests.conftest import TOLERANCES

GL_TOL = TOLERANCES[("gl", "float32")]


def _require_gl():
    status = backend_status()["gl"]
    if not status["available"]:
        pytest.skip(f"backend gl not available: {status['details']}")


def _layouts():
    from ssskit.backends.gl.separable import CPU_LAYOUT, GPU_LAYOUT, Layout

    # the two shipped layouts, and the two mixed storages (each pass reads and writes either kind)
    return [GPU_LAYOUT, CPU_LAYOUT, Layout((8, 8), (8, 32), ("texture", "buffer", "buffer")),
            Layout((32, 2), (16, 4), ("buffer", "texture", "buffer"))]


def _one_region(h=37, w=53, seed=3):
    """A disk of SSS that touches the image's left and top edges, on a tilted depth; random irradiance."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    inside = (xx - 12) ** 2 + (yy - 10) ** 2 < 20**2
    depth = np.where(inside, 300 + 2.0 * xx + yy, np.inf).astype(np.float32)
    return rng.random((h, w, 3)).astype(np.float32), depth, inside.astype(np.int32)


@pytest.mark.parametrize("jitter", [0.0, 0.5])
def test_every_layout_matches_the_oracle(jitter):
    """The GPU's layout (storage buffers with an invalid border instead of bounds tests) runs here on
    llvmpipe too, so CI checks the variant a GPU runs, on one region at the image edges and on three ids."""
    _require_gl()
    from ssskit.backends.gl.separable import SeparableFrame
    from ssskit.screenspace import PassSettings
    from ssskit.screenspace.separable import plan_for

    e, depth, slots = _one_region()
    one = build_separable_plan({1: _taps("preintegrated")}, 90.0, 130.0, jitter=jitter, depth_mode="gaussian")
    gb, taps = _three_materials(40, 56)
    three = plan_for(taps, [1, 2, 3], gb.camera.fx, gb.camera.fy, PassSettings(jitter=jitter, depth_mode="follow"))
    cases = [(one, e, depth, slots), (three, gb.diffuse, gb.depth_mm, three.slot_map(gb.profile_id))]
    for plan, img, z, s in cases:
        ref = NumpyBackend().separable(plan, img, z, s)
        for layout in _layouts():
            frame = SeparableFrame(plan, img, z, s, layout=layout)
            frame.run()
            out = frame.read()
            assert np.abs(out - ref).max() <= GL_TOL, layout


def test_frames_stay_on_the_device_and_results_are_new_arrays():
    """A frame is uploaded once and run again for the next frame (new images, new frame index) with the
    same textures; every read is a new array equal to the oracle of its own frame."""
    _require_gl()
    from ssskit.backends.gl.separable import SeparableFrame

    e, depth, slots = _one_region()
    taps = _taps("preintegrated")
    plans = [build_separable_plan({1: taps}, 120.0, 120.0, jitter=0.4, depth_mode="follow", frame=f, seed=9)
             for f in (0, 1)]
    frame = SeparableFrame(plans[0], e, depth, slots)
    frame.run()
    first = frame.read()
    again = frame.read()
    frame.plan = plans[1]  # the next frame: new irradiance, new jitter angles, same device images
    frame.upload(e[::-1].copy(), depth, slots)
    frame.run()
    second = frame.read()
    assert first is not again and np.array_equal(first, again)
    np.testing.assert_allclose(first, NumpyBackend().separable(plans[0], e, depth, slots), atol=GL_TOL)
    np.testing.assert_allclose(second, NumpyBackend().separable(plans[1], e[::-1], depth, slots), atol=GL_TOL)
    assert np.abs(first - second).max() > 0.01


def test_generated_source_bakes_the_plan_exactly():
    """The constants in the shader are the plan's rows as float32 (what ``ssskit export`` ships)."""
    from ssskit.backends.gl.separable import separable_source

    taps = _taps("svd:2", "marble", 5)
    plan = build_separable_plan({4: taps}, 500.0, 500.0, jitter=0.3, depth_mode="gaussian")
    for term, table in enumerate(plan.terms):
        src = separable_source(plan, term, vertical=True)
        assert "#define VERTICAL 1" in src and f"#define TERM {term}" in src
        block = src[src.index("ROW_PLUS["):src.index(");", src.index("ROW_PLUS["))]
        rows = [[float(x) for x in v.split(",")] for v in re.findall(r"vec4\(([^)]*)\)", block)]
        kmax = len(rows) // (plan.slots * len(plan.terms))
        for s in range(1, plan.slots):
            for k in range(int(table.n_rows[s])):
                got = rows[(term * plan.slots + s) * kmax + k]
                want = np.float32(list(table.w_plus[s, k]) + [table.offsets_mm[s, k]])
                assert np.array_equal(np.float32(got), want)


def test_shader_errors_name_the_line():
    _require_gl()
    from ssskit.backends.gl.context import ShaderError, compile_compute
    from ssskit.errors import BackendError

    source = "#version 430\nlayout(local_size_x = 1) in;\nvoid main() {\n    undefined_name = 1;\n}\n"
    with pytest.raises(ShaderError, match="undefined_name") as info:
        compile_compute(source, "broken")
    assert "line 4" in str(info.value) and "broken compute shader" in str(info.value)
    assert isinstance(info.value, BackendError)


def test_timer_returns_one_usable_figure_per_batch():
    """What holds under any load: one finite, non-negative figure per batch (speed itself is measured by
    benchmarks/bench_gl.py, never asserted here)."""
    _require_gl()
    from ssskit.backends.gl.context import time_gpu
    from ssskit.backends.gl.separable import SeparableFrame

    e, depth, slots = _one_region()
    plan = build_separable_plan({1: _taps("preintegrated")}, 120.0, 120.0, jitter=0.0, depth_mode="follow")
    frame = SeparableFrame(plan, e, depth, slots)
    ms = time_gpu(frame.run, batches=3, batch=2, warmup_ms=1.0)
    assert len(ms) == 3 and all(isinstance(v, float) and np.isfinite(v) and v >= 0 for v in ms)


@pytest.mark.parametrize("bad", [float("nan"), -1.0, float("inf")])
def test_timer_fails_clearly_where_it_cannot_time(bad):
    from ssskit.backends.gl.context import checked_times

    assert checked_times([0.0, 1.5]) == [0.0, 1.5]
    with pytest.raises(BackendError, match="GL timer returned 1 unusable"):
        checked_times([1.0, bad])


def _probe(env_extra=None, prelude=""):
    import os

    env = dict(os.environ, **(env_extra or {}))
    code = (prelude + "\nimport json\nfrom ssskit.backends import backend_status, get_backend\n"
            "s = backend_status()\n"
            "import numpy as np\n"
            "from tests.backends.test_separable import _taps\n"
            "from ssskit.screenspace import filter_arrays\n"
            "out = filter_arrays(np.full((8, 9, 3), 0.5, np.float32), np.full((8, 9), 400.0, np.float32), 300.0,"
            " 300.0, _taps('preintegrated'), backend='numpy')\n"
            "err = None\n"
            "try:\n    get_backend('gl')\nexcept Exception as e:\n    err = f'{type(e).__name__}: {e}'\n"
            "print(json.dumps({'gl': s['gl'], 'cpu_ok': bool(np.allclose(out, 0.5)), 'error': err}))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_without_egl_the_message_says_what_is_missing():
    """Forcing the absence of EGL (the library the context loads does not exist): the gl backend says
    why and what to install; the CPU backends keep working in the same process."""
    got = _probe({"SSSKIT_EGL_LIBRARY": "/nonexistent/libEGL.so.1"})
    assert got["gl"]["available"] is False
    why = got["gl"]["details"]
    assert "EGL" in why and "libegl1" in why and "libgl1-mesa-dri" in why and "/nonexistent/libEGL.so.1" in why
    assert got["cpu_ok"]
    assert got["error"].startswith("BackendError: backend 'gl' is not available")


def test_without_moderngl_the_message_says_pip_install():
    got = _probe(prelude="import sys; sys.modules['moderngl'] = None")
    assert got["gl"]["available"] is False
    assert "moderngl is not installed" in got["gl"]["details"] and "pip install moderngl" in got["gl"]["details"]
    assert got["cpu_ok"]


def test_cli_without_egl(tmp_path):
    import os

    env = dict(os.environ, SSSKIT_EGL_LIBRARY="/nonexistent/libEGL.so.1")
    r = subprocess.run([sys.executable, "-m", "ssskit.cli", "backends"], capture_output=True, text=True, env=env,
                       timeout=300)
    assert r.returncode == 0 and "gl" in r.stdout and "why not: no OpenGL 4.3 context through EGL" in r.stdout
    out = tmp_path / "x.png"
    r = subprocess.run([sys.executable, "-m", "ssskit.cli", "render", "--scene", "slab", "--size", "32x24",
                        "--backend", "gl", "--out", str(out)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "backend 'gl' is not available" in r.stderr
    assert "Traceback" not in r.stderr and not out.exists()
    for args in (["demo", "--out", str(tmp_path / "demo")], ["figures", "xie-fig6", "--out", str(tmp_path / "figs")]):
        r = subprocess.run([sys.executable, "-m", "ssskit.cli", *args, "--backend", "gl"], capture_output=True,
                           text=True, env=env, timeout=300, cwd=tmp_path)
        assert r.returncode == 2 and "backend 'gl' is not available" in r.stderr, (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing written


def test_exported_source_runs_and_matches_the_oracle():
    """The engine export (one file, each pass compiled with its own VERTICAL / TERM defines) is the
    shader the backend runs: compiled from the exported text, a rank-2, jittered frame matches the oracle."""
    _require_gl()
    from ssskit.backends.gl.context import compile_compute
    from ssskit.backends.gl.separable import CPU_LAYOUT, SeparableFrame, export_source

    e, depth, slots = _one_region()
    plan = build_separable_plan({1: _taps("svd:2", "marble", 5)}, 150.0, 120.0, jitter=0.4, depth_mode="gaussian",
                                frame=3, seed=5)
    text = export_source(plan)
    assert "#ifndef VERTICAL" in text and "how to run it" in text

    def compiled(vertical: int, term: int):
        src = text.replace("#version 430\n", f"#version 430\n#define VERTICAL {vertical}\n#define TERM {term}\n", 1)
        return compile_compute(src, "exported separable")

    frame = SeparableFrame(plan, e, depth, slots, layout=CPU_LAYOUT)
    frame.programs = [(compiled(0, r), compiled(1, r)) for r in range(len(plan.terms))]
    frame.run()
    np.testing.assert_allclose(frame.read(), NumpyBackend().separable(plan, e, depth, slots), atol=GL_TOL)

@pytest.mark.parametrize("filtered", [False, True])
def test_burley_one_profile_and_filtered_mips(filtered):
    """One profile (the mask read from the depth's sign, no slots texture) with the mip pyramid, fetched
    texel by texel or through the texture unit's bilinear filter (exact in float32 on llvmpipe; a GPU
    rounds the filter weights, so there the bound is looser)."""
    _require_gl()
    from ssskit.backends.burley_plan import BurleyParams, build_burley_plan
    from ssskit.backends.gl.burley import BurleyFrame
    from ssskit.backends.gl.context import is_software

    e, depth, slots = _one_region(45, 61)
    params = {1: BurleyParams.from_dmfp((0.8, 0.5, 0.3), (3.0, 1.5, 0.8))}
    for sampler in ("exact", "xie"):
        plan = build_burley_plan(params, 300.0, 330.0, sampler=sampler, mips=True, seed=3, frame=2)
        want = NumpyBackend().burley(plan, e, depth, slots, 32)
        frame = BurleyFrame(plan, e, depth, slots, 32, filtered_mips=filtered)
        frame.run()
        got = frame.read()
        frame.release()
        bound = GL_TOL if (is_software() or not filtered) else 5e-3
        share_off = float((np.abs(got - want) > bound).mean())
        assert share_off <= 0.002, (sampler, share_off)


def test_burley_export_source_runs_and_matches_the_oracle():
    """The Burley pass exported for engines (one file, the pyramid's layout in uniforms, so any frame
    size) is the shader the backend runs: compiled from the exported text it matches the oracle."""
    _require_gl()
    from ssskit.backends.burley_plan import BurleyParams, build_burley_plan
    from ssskit.backends.gl.burley import BurleyFrame, burley_export_source
    from ssskit.backends.gl.context import compile_compute

    params = {1: BurleyParams.from_dmfp((0.8, 0.5, 0.3), (3.0, 1.5, 0.8))}
    plan = build_burley_plan(params, 300.0, 330.0, sampler="exact", mips=True, seed=3, frame=2)
    text = burley_export_source(plan)
    assert "how to run it" in text and "u_mip_x" in text
    for h, w in ((45, 61), (30, 34)):  # one source, two frame sizes
        e, depth, slots = _one_region(h, w)
        frame = BurleyFrame(plan, e, depth, slots, 16)
        frame.program = compile_compute(text, "exported Burley")
        frame.run()
        got = frame.read()
        frame.release()
        np.testing.assert_allclose(got, NumpyBackend().burley(plan, e, depth, slots, 16), atol=GL_TOL)


def test_frames_of_different_sizes_keep_their_own_images():
    """Each frame owns its device images: a second frame of another size does not free the first's."""
    _require_gl()
    from ssskit.backends.gl.separable import SeparableFrame

    plan = build_separable_plan({1: _taps("preintegrated")}, 120.0, 120.0, jitter=0.0, depth_mode="follow")
    small, big = _one_region(20, 24), _one_region()
    first = SeparableFrame(plan, *small)
    second = SeparableFrame(plan, *big)
    for frame, (e, depth, slots) in ((first, small), (second, big)):
        frame.run()
        np.testing.assert_allclose(frame.read(), NumpyBackend().separable(plan, e, depth, slots), atol=GL_TOL)
        frame.release()
