"""The screen-space entry points: settings, default depth modes, taps per profile id (the pass itself is
tested on every backend in tests/backends/test_separable.py)."""

import numpy as np
import pytest

from ssskit.errors import PassError, SettingsError
from ssskit.kernels import build_kernel, default_grid
from ssskit.sampling.taps import make_taps
from ssskit.screenspace import Camera, GBuffer, PassSettings, default_depth_mode, filter_arrays, separable_sss


def test_bad_pass_settings(taps7):
    e = np.zeros((4, 4, 3), np.float32)
    d = np.full((4, 4), 1.0, np.float32)
    with pytest.raises(SettingsError, match="jitter"):
        filter_arrays(e, d, 1.0, 1.0, taps7, jitter=2.0)
    with pytest.raises(SettingsError, match="jitter"):
        filter_arrays(e, d, 1.0, 1.0, taps7, jitter=float("nan"))
    with pytest.raises(SettingsError, match="depth_mode"):
        filter_arrays(e, d, 1.0, 1.0, taps7, depth_mode="nope")
    with pytest.raises(SettingsError, match="backend"):
        filter_arrays(e, d, 1.0, 1.0, taps7, backend="cuda")
    with pytest.raises(PassError, match="SeparableTaps"):
        filter_arrays(e, d, 1.0, 1.0, "taps")
    with pytest.raises(PassError, match=r"diffuse must be a real array of shape \(4, 4, 3\), got shape \(4, 4, 1\)"):
        filter_arrays(e[..., :1], d, 1.0, 1.0, taps7)
    with pytest.raises(PassError, match="focal length fx"):
        filter_arrays(e, d, -1.0, 1.0, taps7)


def test_pass_settings_round_trip(tmp_path):
    s = PassSettings(jitter=0.3, depth_mode="Gaussian", frame=4, seed=7, backend="NUMPY")
    assert (s.depth_mode, s.backend) == ("gaussian", "numpy")  # canonical spellings
    for name in ("p.toml", "p.json"):
        s.save(tmp_path / name)
        assert PassSettings.load(tmp_path / name) == s
    (tmp_path / "bad.toml").write_text("jitter = 0.1\nwobble = 2\n")
    with pytest.raises(SettingsError, match="unknown setting.*wobble"):
        PassSettings.load(tmp_path / "bad.toml")


def test_default_depth_mode_follows_the_kernel(skin, taps7):
    """The two-Gaussian model carries its supplement E depth width; tabulated kernels use the follow test."""
    cell, n = default_grid(skin)
    artist = make_taps(build_kernel("artist", skin, cell, n), 7)
    assert default_depth_mode(artist) == "gaussian"
    assert default_depth_mode(taps7) == "follow"
    assert default_depth_mode({1: artist, 2: taps7}) == "follow"


def test_every_profile_id_needs_taps(taps7):
    h, w = 8, 10
    pid = np.ones((h, w), np.uint32)
    pid[:, 5:] = 2
    gb = GBuffer(diffuse=np.ones((h, w, 3), np.float32), albedo=np.ones((h, w, 3), np.float32),
                 depth=np.full((h, w), 300.0, np.float32), profile_id=pid, camera=Camera(w, h, 300.0, 300.0, 5, 4))
    with pytest.raises(PassError, match="no taps given for profile id 2"):
        separable_sss(gb, {1: taps7})
    out = separable_sss(gb, {1: taps7, 2: taps7}, backend="numpy")
    np.testing.assert_allclose(out, 1.0, rtol=1e-12)


def test_unknown_keyword_is_a_settings_error(taps7):
    """A misspelt override (jiter for jitter) is a SettingsError naming the known fields, not a TypeError."""
    h, w = 8, 10
    gb = GBuffer(diffuse=np.full((h, w, 3), 0.5, np.float32), albedo=np.ones((h, w, 3), np.float32),
                 depth=np.full((h, w), 400.0, np.float32), profile_id=np.ones((h, w), np.uint32),
                 camera=Camera(w, h, 1200.0, 1200.0, w / 2, h / 2))
    with pytest.raises(SettingsError, match=r"PassSettings: unknown setting\(s\) jiter \(known: jitter, "):
        separable_sss(gb, taps7, jiter=0.2)
