"""Xie 2020 Fig. 6 (src/ssskit/figures/burley.py): the beam-light disk and the figure file."""

import numpy as np

from ssskit.figures import FIGURES
from ssskit.figures.burley import _params, beam_disk, fig6_xie_inverse


def test_beam_disk_is_a_1cm_disk():
    gb = beam_disk()
    px_per_mm = gb.camera.pixels_per_mm(gb.depth_mm[0, 0])[0]
    assert px_per_mm == 8.0
    area_mm2 = gb.diffuse[..., 0].sum() / px_per_mm**2
    assert abs(area_mm2 - np.pi * 10.0**2) < 0.01 * np.pi * 100  # 1 cm radius, to the pixel grid


def test_fig6_is_registered_and_written(tmp_path):
    from ssskit.profiles import profile_for_material

    assert FIGURES.get("xie-fig6") is fig6_xie_inverse
    burley = profile_for_material("skin1", "burley")
    assert _params(burley).d_mm == tuple(c.d for c in burley.channels)
    assert max(_params(profile_for_material("skin1", "dipole")).d_mm) > 1.0  # Xie's A = 0.9, dmfp 20 mm
    (path,) = fig6_xie_inverse(tmp_path, burley, spp=4)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
