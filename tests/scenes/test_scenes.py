"""Mitsuba-rendered scenes: G-buffers, camera and light paths, frame sequences, path-traced references
(small sizes)."""

import math

import numpy as np
import pytest

from ssskit.materials import Material, get_material
from ssskit.scenes import (
    SCENES,
    SceneError,
    reference_phase_g,
    render_gbuffer,
    render_reference,
    render_sequence,
    scene_camera,
    scene_lights,
)
from ssskit.screenspace import motion_vectors

ALBEDO = (0.6, 0.4, 0.3)


@pytest.mark.parametrize("name", SCENES.names())
def test_scene_gbuffer_is_valid(name):
    gb = render_gbuffer(name, ALBEDO, width=48, height=36, spp=2)
    assert gb.mask.mean() > 0.1
    assert np.all(np.isfinite(gb.depth[gb.mask])) and np.all(gb.depth[gb.mask] > 0)
    np.testing.assert_allclose(gb.albedo[gb.mask], np.broadcast_to(ALBEDO, (int(gb.mask.sum()), 3)), rtol=1e-6)
    assert np.all(np.isfinite(gb.composite()))
    n = np.linalg.norm(gb.normal[gb.mask], axis=1)
    np.testing.assert_allclose(n, 1.0, atol=1e-3)
    assert gb.meta["scene"] == name and gb.meta["frame"] == 0


def test_slab_is_fronto_parallel_at_600_mm():
    gb = render_gbuffer("slab", ALBEDO, width=64, height=48, spp=1)
    assert gb.mask.all()
    np.testing.assert_allclose(gb.depth, 600.0, rtol=1e-5)
    # the straight shadow edge falls on the line x = 0 (the image's middle column)
    lit = gb.diffuse[..., 0].mean(axis=0) > 0.05
    edge = np.flatnonzero(np.diff(lit.astype(int)))
    assert edge.size == 1 and abs(edge[0] + 1 - 32) <= 1


def test_sphere_silhouette_matches_projection():
    """Apparent area of the 30 mm sphere = pi (f tan alpha)^2 with sin alpha = R / distance (on-axis approx)."""
    w, h = 160, 120
    gb = render_gbuffer("sphere", ALBEDO, width=w, height=h, spp=1)
    spec = SCENES.get("sphere")
    cam = scene_camera(spec, w, h)
    d = np.linalg.norm(np.array([0, 0, 30.0]) - np.array(spec.origin))
    alpha = math.asin(30.0 / d)
    expected = math.pi * (cam.fx * math.tan(alpha)) ** 2
    assert gb.mask.sum() == pytest.approx(expected, rel=0.06)
    uv, _ = cam.project(np.array([0, 0, 30.0]))
    assert gb.mask[int(uv[1]), int(uv[0])]


def test_camera_orbit_reprojects_onto_the_same_surface():
    """Frame 3 of the slab's orbit, unprojected with its camera, lies on the slab's top face z = 0."""
    gb = render_gbuffer("slab", ALBEDO, width=48, height=36, spp=1, frame=3)
    world = gb.camera.unproject(np.where(gb.mask, gb.depth, 1.0))
    assert gb.mask.mean() > 0.9
    # one AOV sample per pixel lands anywhere in the pixel: depth varies 600 tan(3 deg) / fx = 0.08 mm per pixel
    assert np.abs(world[gb.mask][:, 2]).max() < 0.045
    assert gb.meta["frame"] == 3


def test_render_sequence_moves_the_camera_along_the_orbit():
    """Two frames of the slab: frame indices in meta, cameras 1 degree apart about the up axis, and the
    motion vectors of frame 1 map its pixels onto the same surface points seen in frame 0."""
    seq = render_sequence("slab", ALBEDO, frames=2, width=48, height=36, spp=1)
    assert [gb.meta["frame"] for gb in seq] == [0, 1]
    a, b = seq
    spec = SCENES.get("slab")
    for gb, f in ((a, 0), (b, 1)):
        assert gb.camera.to_dict() == scene_camera(spec, 48, 36, f).to_dict()
    # the camera centre -R^T t orbits the target (the origin) by orbit_deg_per_frame about +y
    centres = [-(gb.camera.world_to_camera[:3, :3].T @ gb.camera.world_to_camera[:3, 3]) for gb in seq]
    cosang = centres[0] @ centres[1] / (np.linalg.norm(centres[0]) * np.linalg.norm(centres[1]))
    assert math.degrees(math.acos(min(1.0, cosang))) == pytest.approx(spec.orbit_deg_per_frame, abs=1e-6)
    assert centres[0][1] == pytest.approx(centres[1][1])
    assert not np.array_equal(a.depth, b.depth)  # the view turned: the slab's depth is no longer constant
    # reprojection: frame 1's pixels, moved by their motion vectors, land on frame 0 pixels whose depth
    # is the depth of the same surface point in frame 0's camera
    mv = motion_vectors(b.depth, b.camera, a.camera)
    v, u = np.mgrid[0:36, 0:48] + 0.5
    prev = np.stack([u, v], axis=-1) + mv
    inside = b.mask & (prev[..., 0] >= 0) & (prev[..., 0] < 48) & (prev[..., 1] >= 0) & (prev[..., 1] < 36)
    assert inside.mean() > 0.9 and 0 < np.abs(mv[inside]).max() < 1.0  # an orbit about the target: small motion
    _, z_prev = a.camera.project(b.camera.unproject(np.where(b.mask, b.depth, 1.0)))
    iu, iv = prev[..., 0].astype(int), prev[..., 1].astype(int)
    np.testing.assert_allclose(z_prev[inside], a.depth[iv[inside], iu[inside]], atol=0.1)
    later = render_sequence("slab", ALBEDO, frames=1, first=1, width=48, height=36, spp=1)
    np.testing.assert_array_equal(later[0].depth, b.depth)
    with pytest.raises(SceneError, match="frames"):
        render_sequence("slab", ALBEDO, frames=0)
    with pytest.raises(SceneError, match=r"render_sequence: unknown keyword argument\(s\) frame \(known: eta"):
        render_sequence("slab", ALBEDO, frames=2, frame=3)


def test_light_path_moves_the_shadow():
    spec = SCENES.get("sphere")
    c0 = np.array(scene_lights(spec, 0)["key"]["center"])
    c5 = np.array(scene_lights(spec, 5)["key"]["center"])
    target = np.array(spec.target)
    # orbit about the vertical axis through the target: same height, same distance, 30 degrees apart
    assert c5[2] == pytest.approx(c0[2])
    r0, r5 = c0[:2] - target[:2], c5[:2] - target[:2]
    assert np.linalg.norm(r5) == pytest.approx(np.linalg.norm(r0))
    assert math.degrees(math.acos(r0 @ r5 / (r0 @ r0))) == pytest.approx(30.0)
    a = render_gbuffer("sphere", ALBEDO, width=48, height=36, spp=2, frame=0)
    b = render_gbuffer("sphere", ALBEDO, width=48, height=36, spp=2, frame=5)
    assert a.camera.to_dict() != b.camera.to_dict()
    assert not np.allclose(a.diffuse, b.diffuse)


def test_path_traced_reference_is_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    mat = get_material("skin1")
    ref = render_reference("slab", mat, width=24, height=18, spp=2, max_depth=64, chunk_spp=1, progress=False)
    img = ref.image
    assert img.shape == (18, 24, 3) and np.all(np.isfinite(img)) and np.all(img >= 0)
    assert img[:, :8].mean() > img[:, -8:].mean()  # the lit half is brighter than the shadowed half
    assert ref.spp == 2 and ref.chunks == 2 and ref.pixel_se.shape == img.shape
    files = list((tmp_path / "reference").glob("slab-*.npz"))
    assert len(files) == 1
    again = render_reference("slab", mat, width=24, height=18, spp=2, max_depth=64, chunk_spp=1, progress=False)
    np.testing.assert_array_equal(img, again.image)
    np.testing.assert_array_equal(ref.region_se, again.region_se)
    # a jittered camera (SceneSpec.pixel_jitter) is another picture: its own cache entry, never the one above
    import dataclasses

    moved = dataclasses.replace(SCENES.get("slab"), pixel_jitter=(0.5, 0.0))
    render_reference(moved, mat, width=24, height=18, spp=2, max_depth=64, chunk_spp=1, progress=False)
    assert len(list((tmp_path / "reference").glob("slab-*.npz"))) == 2


def test_reference_takes_one_phase_g():
    """Mitsuba's hg phase function takes one g: a per-channel g is refused, not averaged."""
    skin = get_material("skin1")
    assert reference_phase_g(skin) == 0.0
    same = Material("fwd", skin.sigma_a, skin.sigma_s, g=(0.8, 0.8, 0.8), eta=1.4)
    assert reference_phase_g(same) == pytest.approx(0.8)
    mixed = Material("mixed", skin.sigma_a, skin.sigma_s, g=(0.7, 0.8, 0.9), eta=1.4)
    with pytest.raises(SceneError, match=r"one Henyey-Greenstein g .*'mixed' has g = \[0.7, 0.8, 0.9\]"):
        render_reference("slab", mixed, width=8, height=8, spp=1, use_cache=False, progress=False)


def test_bad_scene_inputs():
    with pytest.raises(SceneError, match="unknown scene"):
        render_gbuffer("teapot", ALBEDO)
    with pytest.raises(SceneError, match="width"):
        render_gbuffer("slab", ALBEDO, width=3)
    with pytest.raises(SceneError, match="albedo"):
        render_gbuffer("slab", (2.0, 0.1, 0.1))
    with pytest.raises(SceneError, match="samples per pixel"):
        render_gbuffer("slab", ALBEDO, spp=0)


def test_docs_name_the_boundary_the_code_uses():
    """The boundary is a rough dielectric (Beckmann alpha = COAT_ROUGHNESS) wherever code or docs name it."""
    import ssskit.scenes as scenes
    from ssskit.scenes import gbuffers, reference
    from ssskit.scenes import scenes as specs

    for mod in (scenes, gbuffers, reference, specs):
        doc = mod.__doc__ or ""
        assert "smooth dielectric" not in doc and "``plastic``" not in doc and "later" not in doc
    assert "Beckmann" in specs.__doc__ and "roughdielectric" in reference.render_reference.__doc__


def test_a_gbuffer_is_the_same_on_any_number_of_mitsuba_threads():
    """A first render gives Mitsuba one core less while a thread compiles the pass's kernels
    (ssskit.pipeline.frame.frame_gbuffer): every layer is the same, bit for bit; the count is restored."""
    import drjit as dr

    from ssskit.scenes.mitsuba_variant import mitsuba_threads

    before = dr.thread_count()
    layers = []
    for n in (1, 2):
        with mitsuba_threads(n):
            assert dr.thread_count() == n
            gb = render_gbuffer("sphere", (0.5, 0.4, 0.3), width=48, height=36, spp=4)
        layers.append([getattr(gb, k) for k in ("diffuse", "specular", "albedo", "depth", "normal", "profile_id")])
        assert dr.thread_count() == before
    for one, two in zip(*layers):
        np.testing.assert_array_equal(one, two)


def test_mitsuba_leaves_a_core_only_while_the_thread_beside_it_runs(monkeypatch):
    """leaving_a_core_to: each render that starts while the given thread is alive runs on one thread less
    (at least 1), one after it ended on the whole pool; the count is restored after each render and the block."""
    import threading

    import drjit as dr

    from ssskit.scenes import scenes as sc
    from ssskit.scenes.mitsuba_variant import leaving_a_core_to, mitsuba

    mi = mitsuba()
    before = dr.thread_count()
    seen = []
    real = mi.render
    monkeypatch.setattr(mi, "render", lambda *a, **k: (seen.append(dr.thread_count()), real(*a, **k))[1])
    release = threading.Event()
    busy = threading.Thread(target=release.wait)
    busy.start()
    try:
        with leaving_a_core_to(busy):
            render_gbuffer("sphere", (0.5, 0.4, 0.3), width=16, height=12, spp=1)
            release.set()
            busy.join()
            sc.render_dict(sc.scene_dict(sc.get_scene("sphere"), 16, 12, 1, 0, 0, {"type": "direct"},
                                         lambda sid: {"type": "diffuse"}))
    finally:
        release.set()
    assert seen == [max(1, before - 1)] * 3 + [before]
    assert dr.thread_count() == before


def test_pixel_jitter_moves_what_each_pixel_sees():
    """``SceneSpec.pixel_jitter`` (the TAA's jittered projection): with a jitter of whole pixels, pixel (i, j)
    sees what pixel (i + jx, j + jy) sees unjittered. The sphere's silhouette (its mask) and depth then match the
    unjittered ones shifted by the jitter, up to the few edge pixels whose box-filtered coverage differs by the
    G-buffer's own sampling noise, and match far worse shifted the other way or not at all."""
    import dataclasses

    spec = SCENES.get("sphere")
    w, h, m = 64, 48, 4
    base = render_gbuffer(spec, ALBEDO, width=w, height=h, spp=16)

    def at(g, sx, sy):  # the layers of g at (i + sx, j + sy) for the pixels (i, j) of a window m pixels inside
        win = (slice(m + sy, h - m + sy), slice(m + sx, w - m + sx))
        return g.mask[win], g.depth[win]

    def mismatch(a, b):  # silhouette pixels that differ, and the median depth difference where both see the sphere
        both = a[0] & b[0]
        return int((a[0] ^ b[0]).sum()), float(np.median(np.abs(a[1][both] - b[1][both])))

    for jx, jy in ((2, 0), (0, -3)):
        moved = at(render_gbuffer(dataclasses.replace(spec, pixel_jitter=(float(jx), float(jy))), ALBEDO,
                                  width=w, height=h, spp=16), 0, 0)
        right, wrong, still = (mismatch(moved, at(base, sx, sy)) for sx, sy in ((jx, jy), (-jx, -jy), (0, 0)))
        assert right[0] * 4 < min(wrong[0], still[0]), (right, wrong, still)
        assert right[1] < 0.25 * min(wrong[1], still[1]), (right, wrong, still)
