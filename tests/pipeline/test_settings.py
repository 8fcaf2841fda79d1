"""RenderSettings holds the Burley pass's settings (``method``, ``burley``): TOML/JSON round trips and
bad values named by their key."""

import pytest

from ssskit.errors import SettingsError
from ssskit.pipeline import RenderSettings
from ssskit.screenspace import BurleySettings


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_burley_settings_round_trip(tmp_path, suffix):
    s = RenderSettings(method="burley", width=64, height=48,
                       burley=BurleySettings(sampler="xie", spp=12, c=2.6, mips=False, mip_scale=0.25, stable=True,
                                             bleed=0.3, seed=5, backend="numpy"))
    path = tmp_path / f"frame{suffix}"
    s.save(path)
    back = RenderSettings.load(path)
    assert back == s
    assert back.burley.sampler == "xie" and back.burley.mip_scale == 0.25 and back.method == "burley"
    if suffix == ".toml":
        text = path.read_text()
        assert 'method = "burley"' in text and "[burley]" in text and 'sampler = "xie"' in text


def test_defaults_run_the_separable_pass_with_xie_burley_defaults():
    s = RenderSettings()
    assert s.method == "separable" and s.burley == BurleySettings()
    assert RenderSettings.from_dict({"method": "burley"}).burley == BurleySettings()


@pytest.mark.parametrize("data, key", [
    ({"method": "burley-ish"}, "method"),
    ({"burley": {"sampler": "mis"}}, "sampler"),
    ({"burley": {"spp": 0}}, "spp"),
    ({"burley": {"c": 3.5}}, "c"),
    ({"burley": {"mips": "yes"}}, "mips"),
    ({"burley": {"unknown": 1}}, "burley"),
])
def test_bad_burley_settings_name_their_key(data, key):
    with pytest.raises(SettingsError, match=key):
        RenderSettings.from_dict(data)


def test_render_dispatches_on_method(monkeypatch):
    """pipeline.render runs the Burley pass (with settings.burley) when method = burley."""
    import ssskit.pipeline.burley as pb
    from ssskit.pipeline import render

    seen = {}

    def fake(scene, settings, burley=None, progress=None, params=None):
        seen.update(scene=scene, burley=settings.burley if burley is None else burley)
        return "burley result"

    monkeypatch.setattr(pb, "render_burley", fake)
    s = RenderSettings(method="burley", burley=BurleySettings(spp=7))
    assert render("slab", s) == "burley result"
    assert seen == {"scene": "slab", "burley": BurleySettings(spp=7)}
