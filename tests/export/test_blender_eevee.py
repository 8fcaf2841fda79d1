"""The client: Blender 4.2's EEVEE Next (the viewport's engine, the bpy wheel on EGL) renders ssskit's Blender
export on the slab of ssskit.export.cycles_slab, its edge a spot cone's rim (EEVEE casts no shadow of the
blocker there: docs/exports.md). What is physical is asserted: the plateau is the exported albedo, and
EEVEE's screen-space gather draws the edge narrower than Cycles (the prediction Cycles renders to 1-5 %,
tests/export/test_blender_cycles.py) in every channel; the export's ``eevee`` variant (radius x s(A / max A),
EEVEE's burley_setup) widens green and blue towards s(A'), leaving red. Skips without bpy; slow (two EEVEE
processes, the first compiles its shaders)."""

import numpy as np
import pytest

from ssskit.export import engine_parameters
from ssskit.export.blender import blender_script, compare_slab, eevee_radius_scale, find_blender_python, render_slab
from ssskit.export.engines import slab_material
from ssskit.materials import get_material
from ssskit.profiles import profile_for_material

PYTHON, WHY = find_blender_python()
pytestmark = [pytest.mark.skipif(PYTHON is None, reason=f"no Blender client: {WHY}"), pytest.mark.slow]

#: EEVEE's render: 160 x 32 px per channel view, 64 TAA samples (its gather: 16 samples per pixel each). EEVEE on
#: llvmpipe is not repeatable run to run even with one seed, and more TAA samples do not remove it: red's 25 % distance
#: over Cycles' ranged 0.69-0.87 at 16 samples (4 runs) and 0.80-0.94 at 64 (4 runs; 2026-12-06), so each variant is
#: rendered RUNS times (seeds 5, 6, 7) and the tests read the mean of the runs' ratios
WIDTH, HEIGHT, TAA, RUNS = 160, 32, 64, 3
#: the bias EEVEE's plateau shows (measured 0.976-1.000 for Skin1, Marble; benchmarks/blender_eevee.py)
PLATEAU_TOL = 0.03


@pytest.fixture(scope="module")
def skin1(tmp_path_factory):
    """Per variant, the RUNS comparisons of EEVEE's renders with ssskit's prediction (compare_slab)."""
    _, script, a, d = slab_material("skin1", "dipole", tmp_path_factory.mktemp("eevee"))
    out = {}
    for variant in ("cycles", "eevee"):
        out[variant] = [compare_slab(render_slab(script, list(d), WIDTH, HEIGHT, TAA, seed=5 + run, python=PYTHON,
                                                 timeout=900.0, engine="BLENDER_EEVEE_NEXT", variant=variant),
                                     a, d, trim=0.25) for run in range(RUNS)]
    return a, d, out


def _ratio(runs, c, level):
    """The mean over the runs of channel ``c``'s measured / predicted distance at ``level`` (0: 25 %, 1: 10 %)."""
    qs = [cmp["channels"][c]["distances"][level] for cmp in runs]
    assert all(q["measured_mm"] is not None for q in qs), qs
    return float(np.mean([q["measured_mm"] / q["predicted_mm"] for q in qs]))


def test_plateau_is_the_exported_albedo(skin1):
    _, _, out = skin1
    for variant, runs in out.items():
        for cmp in runs:
            for ch in cmp["channels"]:
                assert abs(ch["plateau_ratio"] - 1.0) < PLATEAU_TOL + 3 * ch["plateau_se"], (variant, ch["plateau_ratio"])


def test_the_viewport_edge_is_narrower_than_the_render(skin1):
    """EEVEE's gather weights the profile with d = radius / (4 pi s(A')) (EEVEE Next's burley_setup), where Cycles
    uses d = radius / (4 pi): the 25 % and 10 % distances it draws are 1 / s(A') of Cycles' (Skin1: 0.96, 0.61,
    0.40), within the 16-sample gather's own bias (measured 0.85-0.95 of that at 64 TAA samples on a quiet machine;
    0.69 for red's mean of 3 runs at a load of 4-5, EEVEE on llvmpipe leaving out subsurface light when the machine
    is busy): asserted in [0.6, 1.3] / s(A') per channel, which red with s = 1.04 and blue with s = 2.47 cannot both
    meet by chance (Cycles' own width, ratio 1, puts blue at 2.47)."""
    a, _, out = skin1
    s = eevee_radius_scale(a)
    for c in range(3):
        for level in (0, 1):
            r = _ratio(out["cycles"], c, level)
            assert 0.6 < r * s[c] < 1.3, (c, level, r, s[c])


def test_the_eevee_variant_undoes_the_albedo_narrowing(skin1):
    """Skin1's s(A') is (1.04, 1.65, 2.47): the variant widens green and blue at 25 % and 10 % by more than
    1 + 0.3 (s / s_red - 1) (1.18 and 1.41; measured 1.23-1.6 and 1.8-2.2 for single runs at 64 TAA samples), red
    by its s = 1.04 within 0.2 (single runs' gains 0.84-1.03: EEVEE's run-to-run spread), and no channel beyond
    Cycles' width."""
    a, _, out = skin1
    s = eevee_radius_scale(a)
    assert s[0] < 1.05 and s[1] > 1.5 and s[2] > 2.0
    for level in (0, 1):
        gain = [_ratio(out["eevee"], c, level) / _ratio(out["cycles"], c, level) for c in range(3)]
        assert abs(gain[0] - s[0]) < 0.2, gain
        assert all(gain[c] > 1 + 0.3 * (s[c] / s[0] - 1) for c in (1, 2)), (gain, s)
        assert all(_ratio(out["eevee"], c, level) < 1.05 for c in range(3)), level


def test_variant_script_sets_the_eevee_radius(tmp_path):
    material = get_material("ketchup")
    params = engine_parameters(profile_for_material(material, "dipole"), "blender", material)
    e = params["eevee"]
    got = np.array(e["subsurface_radius"]) * e["subsurface_scale"]
    want = np.array(params["subsurface_radius"]) * params["subsurface_scale"] * eevee_radius_scale(params["base_color"])
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert "def ssskit_material(name=None, variant=\"cycles\")" in blender_script(params, "ketchup")
