"""The path-traced reference's statistics: independent chunks, consistent standard errors, the
convergence rule, black surroundings (small sizes, the index-matched boundary where the noise allows)."""

import numpy as np
import pytest
from scipy import ndimage

from ssskit.materials import get_material
from ssskit.scenes import SceneError, render_reference, sss_region
from ssskit.scenes.reference import ReferenceRenderer, batch_mean_se, chunk_seed

SKIN = get_material("skin1")


def _neighbour_correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of pixel p + 1 of ``a`` with pixel p of ``b`` (row-major, flattened)."""
    x, y = a.ravel()[1:], b.ravel()[:-1]
    x, y = x - x.mean(), y - y.mean()
    return float(x @ y / np.sqrt((x @ x) * (y @ y)))


def test_chunks_are_independent_streams():
    """Consecutive chunks of one reference share no samples: the noise of pixel p + 1 in one chunk is
    uncorrelated with that of pixel p in the next. With the old scheme (the sampler's base seed i per
    chunk, mi.render without a seed) chunk i + 1 replayed chunk i's random numbers shifted by one
    pixel: this statistic was 0.46 on the same set-up (not 1: the shifted pixel's camera ray differs,
    and row ends break the shift). The noise is isolated as the difference of two chunks, so the
    image's own structure cancels; the same chunk index renders the same image."""
    r = ReferenceRenderer("slab", SKIN, 64, 48, max_depth=256, boundary="index-matched")
    c = [r.chunk(i, 4)[:, 2:28, 0] for i in range(4)]  # the lit plateau, red
    n0, n1 = c[0] - c[2], c[1] - c[3]
    assert np.std(n0) > 0.05 * np.mean(c[0])  # there is noise to correlate
    # ~1250 pixels: the correlation of independent noise has a standard deviation of ~0.03
    assert abs(_neighbour_correlation(n0, n1)) < 0.15
    assert abs(_neighbour_correlation(n1, n0)) < 0.15
    assert abs(float(np.corrcoef(n0.ravel(), n1.ravel())[0, 1])) < 0.15
    np.testing.assert_array_equal(r.chunk(1, 4)[:, 2:28, 0], c[1])


def test_chunk_seeds_are_distinct_and_differ_between_user_seeds():
    seeds = [chunk_seed(s, i) for s in range(4) for i in range(1000)]
    assert len(set(seeds)) == len(seeds)
    assert all(0 <= s < 2**32 for s in seeds)


def test_standard_errors_are_consistent(tmp_path, monkeypatch):
    """Three estimates of one error agree: (1) the batch standard error of the region's mean (spread
    of the chunks' region means), (2) the per-pixel standard errors added in quadrature (valid only
    if distinct pixels are independent), and (3) the observed difference between two references of
    different seeds, which must be a few combined standard errors at most; the error falls as
    1/sqrt(spp)."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    kw = dict(width=32, height=24, chunk_spp=2, max_depth=256, boundary="index-matched", progress=False)
    region = np.zeros((24, 32), bool)
    region[:, 1:14] = True  # the lit plateau
    a = render_reference("slab", SKIN, spp=64, region=region, seed=1, **kw)
    b = render_reference("slab", SKIN, spp=64, region=region, seed=2, **kw)
    assert a.chunks == 32 and a.spp == 64
    mean_px, se_px = a.region_stats(region)
    np.testing.assert_allclose(mean_px, a.region_mean, rtol=1e-5)
    # the batch SE of 32 batches is itself uncertain by ~1/sqrt(2 * 31) = 13%
    np.testing.assert_allclose(a.region_se / se_px, 1.0, atol=0.45)
    z = (a.region_mean - b.region_mean) / np.hypot(a.region_se, b.region_se)
    assert np.all(np.abs(z) < 4.5), z
    c = render_reference("slab", SKIN, spp=16, region=region, seed=3, **kw)
    # 4x fewer samples: 2x the standard error (ratio of two SE estimates with 31 and 7 degrees of freedom)
    ratio = c.region_stats(region)[1] / se_px
    assert np.all((ratio > 1.2) & (ratio < 3.2)), ratio


def test_rendering_continues_until_the_target_or_the_budget(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    kw = dict(width=24, height=18, chunk_spp=2, max_depth=128, boundary="index-matched", progress=False)
    loose = render_reference("slab", SKIN, spp=4, max_spp=512, target_rel_se=0.05, **kw)
    assert loose.converged and np.all(loose.rel_se <= 0.05)
    assert 4 <= loose.spp < 512
    tight = render_reference("slab", SKIN, spp=4, max_spp=8, target_rel_se=1e-4, **kw)
    assert not tight.converged and tight.spp == 8 and np.all(tight.rel_se > 1e-4)
    summary = tight.summary()
    assert summary["converged"] is False and summary["max_spp"] == 8 and summary["target_rel_se"] == 1e-4
    assert summary["boundary"] == "index-matched" and len(summary["rel_se"]) == 3


def test_cache_only_reads_the_cached_render_and_never_renders(tmp_path, monkeypatch):
    """``cache_only`` (the live viewer's lookup): a SceneError where nothing is cached, with no chunk rendered;
    the same image as the render that filled the cache once it is."""
    import ssskit.scenes.reference as reference

    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    kw = dict(width=16, height=12, spp=4, chunk_spp=2, max_depth=64, boundary="index-matched", progress=False)
    rendered = []
    chunk = reference.ReferenceRenderer.chunk
    monkeypatch.setattr(reference.ReferenceRenderer, "chunk", lambda self, *a: rendered.append(a) or chunk(self, *a))
    with pytest.raises(SceneError, match="no path-traced reference of slab"):
        render_reference("slab", SKIN, cache_only=True, **kw)
    assert rendered == []
    first = render_reference("slab", SKIN, **kw)
    n = len(rendered)
    again = render_reference("slab", SKIN, cache_only=True, **kw)
    assert len(rendered) == n and np.array_equal(again.image, first.image)


def test_surroundings_are_black_so_only_the_lights_reach_the_sss_object(tmp_path, monkeypatch):
    """The floor of the sphere scene is black in the reference (it still casts and receives shadows):
    no floor bounce reaches the sphere, as none reaches the G-buffer's direct-light layer."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    kw = dict(width=32, height=24, spp=2, chunk_spp=1, max_depth=64, progress=False)
    black = render_reference("sphere", SKIN, **kw)
    grey = render_reference("sphere", SKIN, surround_albedo=0.5, **kw)
    # floor pixels at least one pixel away from the sphere (a silhouette pixel holds some of both)
    floor = ~ndimage.binary_dilation(sss_region("sphere", 32, 24), iterations=1)
    assert floor.sum() > 100
    assert np.all(black.image[floor] == 0.0)
    assert grey.image[floor].mean() > 0.01
    assert black.surround_albedo == 0.0 and grey.surround_albedo == 0.5


def test_batch_mean_se_is_the_standard_error_of_the_mean():
    rng = np.random.default_rng(0)
    x = rng.normal(3.0, 2.0, size=(40000, 3))
    mean, se = batch_mean_se(x.reshape(400, 100, 3).mean(axis=1))
    np.testing.assert_allclose(mean, 3.0, atol=4 * 0.01)
    np.testing.assert_allclose(se, 2.0 / np.sqrt(40000), rtol=0.15)
    assert np.all(np.isnan(batch_mean_se(x[:1])[1]))


def test_bad_reference_arguments():
    with pytest.raises(SceneError, match="boundary"):
        render_reference("slab", SKIN, width=8, height=8, spp=1, boundary="glass", use_cache=False, progress=False)
    with pytest.raises(SceneError, match="budget"):
        render_reference("slab", SKIN, width=8, height=8, spp=8, max_spp=4, use_cache=False, progress=False)
    with pytest.raises(SceneError, match="relative standard error"):
        render_reference("slab", SKIN, width=8, height=8, spp=1, target_rel_se=0, use_cache=False, progress=False)
    with pytest.raises(SceneError, match="region"):
        render_reference("slab", SKIN, width=8, height=8, spp=1, region=np.zeros((8, 8), bool), use_cache=False,
                         progress=False)
    with pytest.raises(SceneError, match="surround_albedo"):
        render_reference("slab", SKIN, width=8, height=8, spp=1, surround_albedo=2.0, use_cache=False, progress=False)


def test_a_moved_cache_still_holds_a_mesh_scenes_reference(tmp_path, monkeypatch):
    """A reference of a mesh scene (the bumpy tile: its mesh written to the cache, named by its content) is found
    in a copy of the cache in another folder: the key holds the mesh's name in the cache, not the folder (before,
    its absolute path: every copy or move of the cache rendered the references again, under other names)."""
    import shutil

    import ssskit.scenes.reference as reference

    kw = dict(width=16, height=12, spp=2, chunk_spp=2, max_depth=16, boundary="index-matched", progress=False)
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "a"))
    first = render_reference("bumpy", SKIN, **kw)
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path / "b"))
    rendered = []
    monkeypatch.setattr(reference.ReferenceRenderer, "chunk", lambda self, *a: rendered.append(a))
    again = render_reference("bumpy", SKIN, cache_only=True, **kw)
    assert rendered == [] and np.array_equal(again.image, first.image)
    assert str(tmp_path) not in reference.geometry_key(reference.get_scene("bumpy"))
