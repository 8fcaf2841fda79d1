"""G-buffers (layers, EXR files) and the camera."""

import numpy as np
import pytest

from ssskit.errors import GBufferError
from ssskit.screenspace import Camera, GBuffer, load_gbuffer, motion_vectors


def _gbuffer(h=24, w=32, depth=500.0, pid=None, diffuse=None, fx=400.0, fy=None):
    cam = Camera(w, h, fx, fx if fy is None else fy, w / 2, h / 2)
    rng = np.random.default_rng(1)
    return GBuffer(diffuse=rng.random((h, w, 3)).astype(np.float32) if diffuse is None else diffuse,
                   albedo=np.full((h, w, 3), 0.5, np.float32), depth=np.full((h, w), depth, np.float32),
                   profile_id=np.ones((h, w), np.uint32) if pid is None else pid, camera=cam,
                   specular=np.zeros((h, w, 3), np.float32), normal=np.zeros((h, w, 3), np.float32),
                   materials=("Skin1",), meta={"note": "test"})


def test_gbuffer_exr_roundtrip_official_bindings(tmp_path):
    gb = _gbuffer()
    gb.depth[0, 0] = np.inf  # background: allowed where there is no SSS
    gb.profile_id[0, 0] = 0
    p = tmp_path / "g.exr"
    gb.save(p)
    assert p.read_bytes()[:4] == b"\x76\x2f\x31\x01"  # OpenEXR magic number, not TIFF
    back = load_gbuffer(p)
    for name in ("diffuse", "specular", "albedo", "depth", "normal", "profile_id"):
        np.testing.assert_array_equal(getattr(back, name), getattr(gb, name))
    assert back.camera.to_dict() == gb.camera.to_dict()
    assert back.materials == ("Skin1",) and back.meta == {"note": "test"}


def test_a_gbuffer_without_material_names_loads_back(tmp_path):
    """GBuffer.save wrote ``ssskit_materials = []`` for a G-buffer that names no materials (the default), which
    load_gbuffer refuses where profile ids are used (id k is the k-th name): the saved file did not load."""
    gb = _gbuffer()
    unnamed = GBuffer(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id, camera=gb.camera)
    unnamed.save(tmp_path / "g.exr")
    back = load_gbuffer(tmp_path / "g.exr")
    assert back.materials == () and np.array_equal(back.profile_id, gb.profile_id)


@pytest.mark.parametrize("change, layer", [
    (dict(albedo=np.zeros((5, 5, 3), np.float32)), "albedo"),
    (dict(depth=np.full((24, 32), np.nan, np.float32)), "depth"),
    (dict(depth=np.full((24, 32), -1.0, np.float32)), "depth"),
    (dict(depth=np.full((24, 32), 5, np.int32)), "depth"),
    (dict(profile_id=np.ones((24, 32), np.float32)), "profile_id"),
    (dict(diffuse=np.full((24, 32, 3), np.nan, np.float32)), "diffuse"),
    (dict(specular=np.ones((24, 32), np.float32)), "specular"),
])
def test_gbuffer_errors_name_the_layer(change, layer):
    gb = _gbuffer()
    kw = dict(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id, camera=gb.camera)
    kw.update(change)
    with pytest.raises(GBufferError, match=repr(layer)):
        GBuffer(**kw)


def test_gbuffer_file_missing_layer_named(tmp_path):
    import OpenEXR

    p = tmp_path / "partial.exr"
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"diffuse": np.ones((4, 4, 3), np.float32)}) as f:
        f.write(str(p))
    with pytest.raises(GBufferError, match="'albedo'"):
        load_gbuffer(p)
    (tmp_path / "junk.exr").write_bytes(b"not an exr")
    with pytest.raises(GBufferError, match="not an OpenEXR"):
        load_gbuffer(tmp_path / "junk.exr")


def test_camera_unproject_project_and_motion_vectors():
    cam = Camera.from_fov(40, 30, 50.0)
    depth = np.full((30, 40), 200.0)
    uv, z = cam.project(cam.unproject(depth))
    v, u = np.mgrid[0:30, 0:40] + 0.5
    np.testing.assert_allclose(uv[..., 0], u, atol=1e-9)
    np.testing.assert_allclose(z, depth)
    np.testing.assert_allclose(motion_vectors(depth, cam, cam), 0.0, atol=1e-9)
    # previous camera 5 units to the left: points were fx * 5 / z pixels further right
    m = np.eye(4)
    m[0, 3] = 5.0
    prev = Camera(40, 30, cam.fx, cam.fy, cam.cx, cam.cy, m)
    mv = motion_vectors(depth, cam, prev)
    np.testing.assert_allclose(mv[..., 0], cam.fx * 5.0 / 200.0)
    np.testing.assert_allclose(mv[..., 1], 0.0, atol=1e-12)


def test_one_material_name_is_one_material():
    """materials="skin1" names one material (not the characters s, k, i, n, 1)."""
    gb = _gbuffer()
    one = GBuffer(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id,
                  camera=gb.camera, materials="skin1")
    assert one.materials == ("skin1",)
    two = GBuffer(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id * 2,
                  camera=gb.camera, materials=("skin1", "marble"))
    assert two.materials == ("skin1", "marble")
    with pytest.raises(GBufferError, match=r"layer 'profile_id' must lie in \[0, 1\], got 2 \(0 is no SSS, k the k-th of the 1 materials named\)"):
        GBuffer(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id * 2,
                camera=gb.camera, materials="skin1")
    for raw in (b"skin1", [b"skin1"]):  # bytes were split into their codes ('115', '107', ...)
        with pytest.raises(GBufferError, match="materials must be names"):
            GBuffer(diffuse=gb.diffuse, albedo=gb.albedo, depth=gb.depth, profile_id=gb.profile_id,
                    camera=gb.camera, materials=raw)
