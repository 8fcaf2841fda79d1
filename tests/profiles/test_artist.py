"""Materials from artists' terms: the Monte Carlo inversion checked by MCML itself (the asked albedo within
1 %, the asked width within 3 %), the shipped table re-simulated within its standard errors, the Burley-fit
alternative, and the model's domain."""

import json
import math

import numpy as np
import pytest

from ssskit.errors import MaterialError
from ssskit.materials import get_material
from ssskit.profiles.montecarlo import MonteCarloProfile
from ssskit.profiles.artist import (
    ArtistMaterial,
    artist_table,
    burley_from_artist,
    material_from_artist,
    mcml_rd_r50,
    predicted_r50_mm,
    TABLE_PATH,
)

PHOTONS = 100_000


def _check_mcml(inv, asked_albedo, asked_r50=None, asked_d=None):
    """MCML of the inverted material: total Rd within 1 % of the asked albedo; r50, or the Burley d fitted to
    the profile (the engines' fit), within 3 % of the asked width."""
    from ssskit.export.engines import fit_burley_channel
    from ssskit.profiles.artist import mcml_run, r50_of_result

    for c in range(3):
        res = mcml_run(inv.sigma_a[c], inv.sigma_s[c], inv.g[c], inv.eta, PHOTONS, seed=11 + c)
        assert abs(res.total_rd / asked_albedo[c] - 1.0) < 0.01, (c, res.total_rd, res.total_rd_se, asked_albedo[c])
        if asked_r50 is not None:
            r50 = r50_of_result(res.r_mm, res.rd, res.config.dr_mm, res.total_rd)
            assert abs(r50 / asked_r50[c] - 1.0) < 0.03, (c, r50, asked_r50[c])
        if asked_d is not None:
            d = fit_burley_channel(MonteCarloProfile(res))[1]
            assert abs(d / asked_d[c] - 1.0) < 0.03, (c, d, asked_d[c])


@pytest.mark.parametrize("name", ["skin1", "marble"])
def test_albedo_and_mfp_invert_to_the_preset(name):
    """Skin1's and Marble's own MCML albedo (overflow included) and volume mean free path 1/sigma_t give back
    coefficients whose MCML run has that albedo (1 %) and the width the table predicts (3 %)."""
    m = get_material(name)
    albedo = [mcml_rd_r50(m.sigma_a[c], m.sigma_s[c], 0.0, m.eta, PHOTONS, seed=3 + c)[0] for c in range(3)]
    inv = material_from_artist(ArtistMaterial(name, tuple(albedo), m.mfp_mm, "mfp", m.eta, 0.0))
    np.testing.assert_allclose(inv.sigma_t, m.sigma_t, rtol=1e-12)  # mfp = 1 / sigma_t exactly
    np.testing.assert_allclose(inv.sigma_s, m.sigma_s, rtol=0.01)
    if name == "skin1":  # at Marble's albedo (alpha' > 0.999) Rd hardly moves with sigma_a
        np.testing.assert_allclose(inv.sigma_a, m.sigma_a, rtol=0.03)
    _check_mcml(inv, albedo, asked_r50=predicted_r50_mm(inv))


@pytest.mark.parametrize("name", ["skin1", "marble"])
def test_albedo_and_dmfp_give_the_asked_width(name):
    """Burley's (A, d) of the preset as (A, diffuse mean free path d (3.5 + 100 (A - 0.33)^4)): MCML of the
    inverted material has albedo A (1 %) and, fitted by Burley as every engine export fits it, length d (3 %)."""
    from ssskit.export import fit_burley
    from ssskit.profiles import profile_for_material

    m = get_material(name)
    a, d = fit_burley(profile_for_material(m, "dipole"))
    dmfp = d * (3.5 + 100.0 * (a - 0.33) ** 4)
    inv = material_from_artist(ArtistMaterial(name, tuple(a), tuple(dmfp), "dmfp", m.eta, 0.0))
    _check_mcml(inv, a, asked_d=d)


def test_anisotropy_keeps_the_reduced_coefficients():
    """With g the similarity relation keeps alpha' and sigma_t' ([JMLH01]): g = 0.8 and g = 0 agree there."""
    kw = dict(name="x", albedo=(0.5, 0.3, 0.1), distance_mm=(2.0, 1.0, 0.5), kind="dmfp", eta=1.4)
    m0 = material_from_artist(ArtistMaterial(g=0.0, **kw))
    m8 = material_from_artist(ArtistMaterial(g=0.8, **kw))
    np.testing.assert_allclose(m8.sigma_t_reduced, m0.sigma_t_reduced, rtol=1e-12)
    np.testing.assert_allclose(m8.albedo_reduced, m0.albedo_reduced, rtol=1e-12)


@pytest.mark.parametrize("i_eta,i_ap", [(1, 3), (1, 14), (3, 8), (0, 22)])
def test_table_entries_resimulate(i_eta, i_ap):
    """A few shipped entries, simulated again with other seeds: within 4 combined standard errors."""
    t = artist_table()
    eta, ap = t["eta"][i_eta], t["alpha_reduced"][i_ap]
    from ssskit.export.engines import fit_burley_channel
    from ssskit.profiles.artist import mcml_run, r50_of_result

    runs = []
    for s in range(t["seeds"]):
        res = mcml_run(1.0 - ap, ap, 0.0, eta, t["photons"], seed=1000 + s)
        r50 = r50_of_result(res.r_mm, res.rd, res.config.dr_mm, res.total_rd)
        runs.append((res.total_rd, r50, fit_burley_channel(MonteCarloProfile(res))[1]))
    for k, j in (("rd", 0), ("r50", 1), ("burley_d", 2)):
        vals = [r[j] for r in runs]
        mean, se = float(np.mean(vals)), float(np.std(vals, ddof=1) / math.sqrt(len(vals)))
        ref, ref_se = t[k][i_eta][i_ap], t[f"{k}_se"][i_eta][i_ap]
        assert abs(mean - ref) < 4.0 * math.hypot(se, ref_se) + 1e-6 * ref, (k, mean, ref, se, ref_se)


def test_table_is_small_and_monotone():
    assert TABLE_PATH.stat().st_size < 50_000
    t = json.loads(TABLE_PATH.read_text())
    for rd in t["rd"]:
        assert all(np.diff(rd) < 0)  # Rd falls as alpha' falls (the grid runs from high alpha' down)


def test_burley_fit_inversion():
    art = ArtistMaterial("x", (0.5, 0.3, 0.1), (2.0, 1.0, 0.5), "dmfp")
    a, d = burley_from_artist(art)
    np.testing.assert_allclose(d * (3.5 + 100 * (a - 0.33) ** 4), art.distance_mm)
    a, d = burley_from_artist(ArtistMaterial("x", (0.5, 0.3, 0.1), (2.0, 1.0, 0.5), "mfp"))
    np.testing.assert_allclose(d * (1.85 - a + 7 * np.abs(a - 0.8) ** 3), (2.0, 1.0, 0.5))


@pytest.mark.parametrize("kw,fragment", [
    (dict(albedo=(1.2, 0.5, 0.3)), "must lie in (0, 1]"),
    (dict(albedo=(0.0, 0.5, 0.3)), "must lie in (0, 1]"),  # A = 0: R(r) = 0, as render's Burley pass refuses it
    (dict(distance_mm=(1.0, 0.0, 1.0)), "the dmfp distance must lie in [1e-06, 1e+06] mm, got (1, 0, 1)"),
    (dict(distance_mm=(1.0, -2.0, 1.0)), "must lie in [1e-06, 1e+06] mm, got (1, -2, 1)"),
    # the export wrote subsurface_scale 3.6e6 from --dmfp 1e9: the mean free paths every model takes
    (dict(distance_mm=(1e9, 1.0, 1.0)), "in [1e-06, 1e+06] mm"),
    (dict(distance_mm=(1.0, 1e-9, 1.0), kind="mfp"), "the mfp distance must lie in [1e-06, 1e+06] mm"),
    (dict(eta=0.9), "eta must lie in [1, inf), got 0.9"),
    (dict(g=1.0), "g must lie in (-1, 1), got 1"),
    (dict(kind="radius"), "distance kind"),
])
def test_domain(kw, fragment):
    base = dict(name="x", albedo=(0.5, 0.3, 0.1), distance_mm=(2.0, 1.0, 0.5), kind="dmfp", eta=1.3, g=0.0)
    with pytest.raises(MaterialError, match=None) as info:
        ArtistMaterial(**{**base, **kw})
    assert fragment in str(info.value)


def test_the_domain_ends_are_taken():
    """A = 1 (no absorption: Burley's R(r) integrates to 1) and the range's ends are inside."""
    a, d = burley_from_artist(ArtistMaterial("x", (1.0, 0.5, 0.1), (1e-6, 1.0, 1e6), "dmfp"))
    np.testing.assert_allclose(d[0], 1e-6 / 23.6512, rtol=1e-5)  # 3.5 + 100 (1 - 0.33)^4 = 23.6512
