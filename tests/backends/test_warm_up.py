"""Backend.warm_up: the numba backend compiles, before any real frame, the very specialisations real frames call
(so a warm-up overlapped with other work, in a thread or another process, leaves the first frame nothing to
compile), and it names what it cannot warm up."""

import numpy as np
import pytest

from ssskit.backends.base import WARM_UP
from ssskit.errors import BackendError


def _dispatchers() -> dict:
    """Every numba function of the numba backend's kernels, by name."""
    from numba.core.registry import CPUDispatcher

    from ssskit.backends import _numba_adaptive, _numba_burley, _numba_separable, _numba_transmission

    return {f"{m.__name__}.{k}": v for m in (_numba_adaptive, _numba_burley, _numba_separable, _numba_transmission)
            for k, v in vars(m).items() if isinstance(v, CPUDispatcher)}


def test_real_frames_compile_nothing_after_the_warm_up():
    """Warm every pass up, then run real frames of every pass through the pipeline (a Mitsuba G-buffer with two
    materials, each depth mode, the Burley pass with and without mips, the adaptive run, transmission):
    no numba function gains a specialisation. (A type that differs between the tiny frames and a real one,
    an int64 for an int32 or a view for a copy, makes the real frame compile again: this fails.)"""
    from ssskit.backends.numba_backend import NumbaBackend
    from ssskit.pipeline import AdaptivePass, BurleyPass, RenderSettings, SeparablePass, render
    from ssskit.scenes import render_gbuffer

    NumbaBackend().warm_up(WARM_UP)
    before = {k: len(d.overloads) for k, d in _dispatchers().items()}
    assert before["ssskit.backends._numba_separable.pass_follow"] >= 1 and before[
        "ssskit.backends._numba_burley.burley_rows"] >= 1
    # two materials (profile ids 1, 2) on a back-lit scene with the light layers: every kernel's real inputs
    gb = render_gbuffer("ear", (0.5, 0.4, 0.3), eta=1.4, width=32, height=24, spp=1, material="skin1",
                        light_layers=True)
    ids = np.where(np.arange(32) < 16, 1, 2)[None, :] * gb.mask
    gb = gb.with_layers(profile_id=ids.astype(np.uint32), materials=("skin1", "marble"))
    assert set(np.unique(gb.profile_id)) == {0, 1, 2}
    base = dict(backend="numba", perceptual=False, exact=False)
    for mode in ("follow", "gaussian", "none"):
        render(gb, RenderSettings(**base, model="dipole", pass_=SeparablePass(depth_mode=mode)))
    render(gb, RenderSettings(**base, model="dipole", kernel="artist"))  # its default depth mode
    for mips, sampler in ((True, "xie"), (False, "exact")):
        render(gb, RenderSettings(**base, pass_=BurleyPass(spp=2, mips=mips, sampler=sampler)))
    render("slab", RenderSettings(backend="numba", perceptual=False, width=32, height=24, spp=1,
                                  pass_=AdaptivePass(frames=3, b_max=8, limit_spp=8)))
    after = {k: len(d.overloads) for k, d in _dispatchers().items()}
    assert {k: (before[k], n) for k, n in after.items() if n != before[k]} == {}


def test_an_unknown_pass_is_named():
    from ssskit.backends import get_backend

    with pytest.raises(BackendError, match="the pass to warm up must be one of separable:gaussian, .*, got 'separable:fast'"):
        get_backend("numpy").warm_up(["separable:fast"])
    get_backend("numpy").warm_up(WARM_UP)  # nothing to prepare
