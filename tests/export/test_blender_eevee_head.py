"""The client on the head: Cycles and Blender 4.2's EEVEE Next (the bpy wheel; EEVEE headless on EGL) render ssskit's
Blender export on the scanned head (the mesh ssskit renders, 259 mm per unit; the close view of the left cheek; the
head's key light without cast shadow, so the light ends at the terminator, N . L = 0, the same line in both
engines: ssskit.export.blender_head). Asserted: what is physical (Cycles keeps the exported albedo on the lit skin,
and light crosses the terminator only through subsurface transport) and what ssskit predicts in kind (the ``eevee``
variant, radius x s(A'), widens green and blue, blue the more, and leaves red). EEVEE's own spill on llvmpipe depends
on the machine's load, so no number of it is asserted. Skips without bpy; slow (one bpy process: a Cycles render and
three EEVEE renders per variant at 160 x 120)."""

import numpy as np
import pytest

from ssskit.export.blender import eevee_radius_scale, find_blender_python
from ssskit.export.blender_head import compare_head, dark_mask, spill
from ssskit.export.engines import slab_material

PYTHON, WHY = find_blender_python()
needs_bpy = pytest.mark.skipif(PYTHON is None, reason=f"no Blender client: {WHY}")

#: 160 x 120 px (0.37 mm per pixel on the cheek), EEVEE 64 TAA samples, Cycles 64 spp. Over 3 EEVEE renders in one
#: process (2026-12-06, benchmarks/blender_eevee_head.py and /tmp runs of this fixture) EEVEE's spill over Cycles'
#: for Skin1 ranged R 0.58-0.72, G 0.29-0.43, B 0.17-0.35 (cycles export) and R 0.58-0.72, G 0.89-1.31, B 1.05-1.92
#: (eevee variant): the gain of the variant R 0.99-1.21, G 2.5-4.3, B 4.2-10.4; the benchmark's 3 renders (Cycles
#: 256 spp) gave R 0.60-0.65, G 0.32-0.41, B 0.20-0.32 and gains R 0.96-1.07, G 2.4-3.4, B 3.9-7.2
#: a single render's red gain fell outside [0.75, 1.35] once in the slow set (2026-12-06), so the tests read the mean
#: of REPEATS EEVEE renders per variant
WIDTH, HEIGHT, TAA, SPP, REPEATS = 160, 120, 64, 64, 3


@pytest.fixture(scope="module")
def skin1(tmp_path_factory):
    _, script, a, _ = slab_material("skin1", "dipole", tmp_path_factory.mktemp("eevee_head"))
    return a, compare_head(script, a, WIDTH, HEIGHT, "close", TAA, SPP, repeats=REPEATS, python=PYTHON)


def _mean_spill_ratio(cmp, variant):
    """EEVEE's spill over Cycles' per channel, the mean over the repeats of ``variant``."""
    return np.mean([run["spill_ratio"] for run in cmp["eevee"][variant]], axis=0)


@needs_bpy
@pytest.mark.slow
def test_cycles_keeps_the_albedo_on_the_lit_skin(skin1):
    """Measured 0.987 / 0.997 / 1.000: red, the widest channel (d = 1.15 mm), loses 1.3 % past the terminator and
    the nose's curve; within 3 % (a specular-free Burley BSSRDF's plateau is its base colour)."""
    a, cmp = skin1
    assert np.all(np.abs(np.array(cmp["cycles_plateau"]) - 1.0) < 0.03), cmp["cycles_plateau"]
    assert cmp["dark_pixels"] > 1000 and all(v > 0 for v in cmp["cycles_spill"]), cmp


@needs_bpy
@pytest.mark.slow
def test_the_eevee_variant_widens_green_and_blue_in_the_order_of_s(skin1):
    """Skin1's s(A') = (1.04, 1.65, 2.47): the variant multiplies the radius EEVEE reads by s(A'), so the spill past
    the terminator grows in green and blue (gain above 1) and more in blue than in green (s_B > s_G), and red, s =
    1.04, stays within [0.6, 1.4]. Not asserted: by how much, nor EEVEE's spill against Cycles' (the viewport-versus-
    render number): on llvmpipe both depend on the machine's load (docs/exports.md, "EEVEE Next and Cycles render the
    Blender export on the head"): the Cycles export's spill ratio was 0.95-1.35 at load 1.4 and 0.32-0.88 at load
    3.5-6.5, and the gains G 2.3 / B 3.9 and 1.7-2.5 / 2.4-3.9 (2026-12-06)."""
    a, cmp = skin1
    s = eevee_radius_scale(a)
    gain = _mean_spill_ratio(cmp, "eevee") / _mean_spill_ratio(cmp, "cycles")
    assert 0.6 < gain[0] < 1.4, gain
    assert 1.0 < gain[1] < gain[2] and s[1] < s[2], (gain, s)


def test_spill_is_zero_without_subsurface_transport_and_counts_only_the_dark_pixels():
    """A Lambertian image (A E / pi) spills nothing; light put in the dark pixels is counted over the albedo."""
    rng = np.random.default_rng(3)
    white = rng.uniform(0.2, 1.0, (20, 30, 3))
    white[:, :10] = 0.0
    a = np.array([0.5, 0.25, 0.125])
    dark = dark_mask([white, white * 1.01])
    assert dark.sum() == 200
    np.testing.assert_array_equal(spill(white * a, a, dark), 0.0)
    img = white * a
    img[:, 9] = 0.01
    np.testing.assert_allclose(spill(img, a, dark), 20 * 0.01 / a)


@needs_bpy
def test_the_eevee_settings_keep_shadows_on():
    """The defect of docs/engines/eevee-sun-shadow.md: bpy 4.2.0's deprecated ``use_bloom = False`` clears
    ``use_shadows`` (and soft shadows, TAA reprojection), and EEVEE Next then casts no shadow. The scenes' EEVEE
    settings (``cycles_slab._eevee``, which ``head_scene.py`` shares) must leave shadows on."""
    import subprocess
    from pathlib import Path

    import ssskit.export

    folder = Path(ssskit.export.__file__).parent
    code = ("import sys; sys.path.insert(0, sys.argv[1]); import bpy, cycles_slab; s = bpy.context.scene; "
            "cycles_slab._eevee(s, 4, {}); print('SHADOWS', s.eevee.use_shadows, s.eevee.use_soft_shadows)")
    proc = subprocess.run([PYTHON, "-c", code, str(folder)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "SHADOWS True True" in proc.stdout, proc.stdout[-2000:]
