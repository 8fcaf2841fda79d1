"""RenderSettings is one tree: frame, seed and backend once, the pass as one tagged member written as one
table ([separable], [burley] or [adaptive]); TOML/JSON round trips, bad values named by their key, the
files of the layout before the tree (method, [sss], frame/seed/backend per pass) still load."""

import warnings

import numpy as np
import pytest

from ssskit.errors import SettingsError
from ssskit.pipeline import PASSES, AdaptivePass, BurleyPass, RenderSettings, SeparablePass
from ssskit.pipeline.settings import SettingsMigrated
from ssskit.screenspace import BurleySettings, PassSettings


@pytest.mark.parametrize("suffix", [".toml", ".json"])
@pytest.mark.parametrize("member", [SeparablePass(jitter=0.3, depth_mode="follow"),
                                    BurleyPass(sampler="xie", spp=12, c=2.6, mips=False, mip_scale=0.25, stable=True,
                                               bleed=0.3, albedo=(0.8, 0.5, 0.3), dmfp_mm=(2.0, 1.0, 0.5)),
                                    AdaptivePass(sigma0_sq=1e-4, kappa=0.6, b_min=4, b_max=32, frames=5,
                                                 limit_spp=256, disocclusion_spp=16, taa=False)])
def test_round_trip_holds_one_pass_table(tmp_path, suffix, member):
    # the transmittance pass runs with every pass (the adaptive run adds it to each frame)
    light = {"transmission": "on", "transmission_model": "jimenez2010"}
    s = RenderSettings(width=64, height=48, seed=5, frame=2, backend="numpy", pass_=member, **light)
    path = tmp_path / f"frame{suffix}"
    s.save(path)
    back = RenderSettings.load(path)
    assert back == s and back.pass_name == member.name
    assert (back.transmission, back.transmission_model) == (s.transmission, s.transmission_model)
    if suffix == ".toml":
        text = path.read_text()
        tables = [line for line in text.splitlines() if line.startswith("[")]
        assert tables == [f"[{member.table}]"]  # one pass table; frame, seed and backend at the top
        assert text.count("seed = ") == 1 and text.count("backend = ") == 1 and text.count("frame = ") == 1


def test_the_pass_level_settings_take_frame_seed_and_backend_from_the_tree():
    s = RenderSettings(seed=7, frame=3, backend="numpy", pass_=BurleyPass(spp=9, sampler="golubev"))
    assert s.burley_settings() == BurleySettings(sampler="golubev", spp=9, seed=7, frame=3, backend="numpy")
    sep = RenderSettings(seed=7, frame=3, backend="numpy", pass_=SeparablePass(jitter=0.2))
    assert sep.pass_settings() == PassSettings(jitter=0.2, seed=7, frame=3, backend="numpy")
    a = RenderSettings(pass_=AdaptivePass(kappa=0.5)).adaptive_settings()
    assert a.kappa == 0.5
    with pytest.raises(SettingsError, match="not a Burley one"):
        sep.burley_settings()
    with pytest.raises(SettingsError, match="not the separable one"):
        s.pass_settings()


def test_transmission_settings_are_canonical_and_default_to_auto():
    s = RenderSettings()
    assert (s.transmission, s.transmission_model) == ("auto", "mcml")
    t = RenderSettings(transmission=" ON ", transmission_model="Jimenez2010", pass_=BurleyPass())
    assert (t.transmission, t.transmission_model) == ("on", "jimenez2010")
    assert RenderSettings.from_dict(t.to_dict()) == t


def test_defaults_run_the_separable_pass():
    s = RenderSettings()
    assert s.pass_name == "separable" and s.pass_ == SeparablePass()
    assert RenderSettings.from_dict({"burley": {}}).pass_ == BurleyPass()
    assert PASSES.names() == ["separable", "burley", "burley-adaptive"]


@pytest.mark.parametrize("data, key", [
    ({"burley": {"sampler": "mis"}}, "sampler"),
    ({"burley": {"spp": 0}}, "spp"),
    ({"burley": {"c": 3.5}}, "c"),
    ({"burley": {"mips": "yes"}}, "mips"),
    ({"burley": {"unknown": 1}}, "burley"),
    ({"burley": {"c": 2.6}}, "c applies to sampler xie, not sampler exact"),
    ({"burley": {"albedo": 0.5}}, "dmfp_mm go together"),
    ({"adaptive": {"b_min": 64, "b_max": 8}}, "b_min <= b_max"),
    ({"adaptive": {"static": True, "limit_spp": 64}}, "limit_spp applies to camera moving, not camera static"),
    ({"adaptive": {"disocclusion_spp": 65}}, "disocclusion_spp"),
    ({"separable": {"jitter": 2}}, "jitter"),
    ({"separable": {}, "burley": {}}, "one pass per render"),
    ({"kernel": "svd:2", "burley": {}}, "kernel applies to pass separable, not pass burley"),
    ({"frame": -1}, "frame"),
    ({"backend": "cuda"}, "backend"),
    ({"nonsense": 1}, "nonsense"),
    ({"transmission": "yes"}, "transmission must be one of auto, on, off"),
    ({"transmission": True}, "transmission must be one of"),
    ({"transmission_model": "unreal2"}, "transmission_model must be one of mcml, jimenez2010, unreal"),
    ({"transmission": "off", "transmission_model": "jimenez2010"}, "transmission_model applies to transmission auto or on, not transmission off"),
])
def test_bad_settings_name_their_key(data, key):
    with pytest.raises(SettingsError, match=key):
        RenderSettings.from_dict(data)


# ---- the layout before the tree: yesterday's files ---------------------------------------------------------

#: a file as the layout before the tree saved it (every field, both pass tables, method)
OLD_BURLEY = """material = "skin1"
model = "dipole"
photons = 200000
kernel = "preintegrated"
taps = 7
tap_method = "importance"
width = 64
height = 48
spp = 32
seed = 4
exact = true
reference = false
reference_spp = 64
reference_max_spp = 1024
reference_rel_se = 0.01
perceptual = false
method = "burley"

[sss]
jitter = 0.1
frame = 0
seed = 0
backend = "numba"

[burley]
sampler = "xie"
spp = 8
c = 2.6
sequence = "r2"
bleed = 0.0
frame = 2
seed = 4
stable = false
mips = false
mip_scale = 0.0625
backend = "numpy"
"""


def _load_old(tmp_path, text):
    path = tmp_path / "old.toml"
    path.write_text(text)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        s = RenderSettings.load(path)
    assert [w.category for w in seen] == [SettingsMigrated]
    return s


def test_an_old_burley_file_loads_as_the_tree(tmp_path):
    s = _load_old(tmp_path, OLD_BURLEY)
    assert s.pass_ == BurleyPass(sampler="xie", spp=8, c=2.6, mips=False)
    assert (s.frame, s.seed, s.backend, s.width, s.perceptual) == (2, 4, "numpy", 64, False)
    assert s.burley_settings() == BurleySettings(sampler="xie", spp=8, c=2.6, mips=False, frame=2, seed=4,
                                                 backend="numpy")  # what the old pass ran with


def test_an_old_separable_file_loads_as_the_tree(tmp_path):
    """The separable pass read its jitter, frame, seed and backend from [sss]; the [burley] table beside it,
    at its defaults, was never read."""
    head = OLD_BURLEY[:OLD_BURLEY.index('method = "burley"')].replace("seed = 4\n", "")
    text = (head + 'method = "separable"\n\n[sss]\njitter = 0.3\nframe = 1\nseed = 4\nbackend = "numpy"\n\n'
            '[burley]\nsampler = "exact"\nspp = 32\nbackend = "numba"\n')
    s = _load_old(tmp_path, text)
    assert s.pass_ == SeparablePass(jitter=0.3) and (s.frame, s.seed, s.backend) == (1, 4, "numpy")
    assert s.pass_settings() == PassSettings(jitter=0.3, frame=1, seed=4, backend="numpy")


def test_an_old_file_the_tree_cannot_hold_is_refused(tmp_path):
    two_seeds = OLD_BURLEY.replace("seed = 4\nstable", "seed = 9\nstable")
    with pytest.raises(SettingsError, match=r"seed = 4 and \[burley\] seed = 9 disagree; give seed once"):
        _load_old(tmp_path, two_seeds)
    unread = OLD_BURLEY.replace("[sss]\njitter = 0.1", "[sss]\njitter = 0.5")
    with pytest.raises(SettingsError, match=r"the \[sss\] table's jitter applies to method separable, not method burley"):
        _load_old(tmp_path, unread)


def test_render_dispatches_on_the_pass(monkeypatch):
    """pipeline.render runs the pass the settings name."""
    import importlib

    from ssskit.pipeline import render

    pr = importlib.import_module("ssskit.pipeline.render")  # the module, which the package's `render` shadows

    seen = {}

    def fake_burley(scene, settings, progress=None, params=None):
        seen.update(scene=scene, burley=settings.burley_settings())
        return "burley result"

    monkeypatch.setattr(pr, "render_burley", fake_burley)
    monkeypatch.setattr(pr, "render_adaptive", lambda scene, settings, **kw: "adaptive result")
    s = RenderSettings(pass_=BurleyPass(spp=7))
    assert render("slab", s) == "burley result"
    assert seen == {"scene": "slab", "burley": BurleySettings(spp=7)}
    assert render("slab", RenderSettings(pass_=AdaptivePass())) == "adaptive result"
    with pytest.raises(SettingsError, match="on_frame applies to pass burley-adaptive, not pass separable"):
        render("slab", RenderSettings(), on_frame=print)


def test_unknown_keywords_and_materials_are_settings_errors():
    """A misspelt keyword is a SettingsError in from_dict's wording (not Python's TypeError), for every settings
    class; a material that is neither a preset nor a material file is refused when the settings are made (a
    file path is kept for the render to read)."""
    for make, bad in ((RenderSettings, "kernal"), (PassSettings, "jiter"), (BurleySettings, "spps")):
        with pytest.raises(SettingsError, match=rf"{make.__name__}: unknown setting\(s\) {bad} \(known: "):
            make(**{bad: 1})
    with pytest.raises(SettingsError, match="material 'skin9' is neither a preset"):
        RenderSettings(material="skin9")
    assert RenderSettings(material="Skin2").material == "Skin2"
    assert RenderSettings(material="my/own.toml").material == "my/own.toml"


def test_frames_have_one_limit():
    """An adaptive run's frames have one limit, ssskit.settings.FRAMES_RANGE, in the render settings
    (AdaptivePass), adaptive_frames and sequence_gbuffers alike (both checked before any work)."""
    from ssskit.pipeline.sequence import sequence_gbuffers
    from ssskit.screenspace import BurleyParams, Camera, GBuffer
    from ssskit.screenspace.frames import adaptive_frames
    from ssskit.settings import FRAMES_RANGE

    top = FRAMES_RANGE[1]
    assert AdaptivePass(frames=top).frames == top
    gb = GBuffer(diffuse=np.zeros((4, 4, 3), np.float32), albedo=np.ones((4, 4, 3), np.float32),
                 depth=np.full((4, 4), 400.0, np.float32), profile_id=np.ones((4, 4), np.uint32),
                 camera=Camera(4, 4, 100.0, 100.0, 2.0, 2.0))
    for call in (lambda: AdaptivePass(frames=top + 1),
                 lambda: adaptive_frames(gb, BurleyParams.from_dmfp(0.6, (1.0, 1.0, 1.0)), frames=top + 1,
                                         history=np.zeros((1, 1, 4), np.float32)),  # (wrong: checked after frames)
                 lambda: sequence_gbuffers("sphere", "skin1", top + 1)):
        with pytest.raises(SettingsError, match=rf"frames must lie in \[1, {top}\], got {top + 1}"):
            call()
