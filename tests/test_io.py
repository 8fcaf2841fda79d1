"""File I/O: atomic writes (modes from the umask), output-over-input checks, images, OpenEXR reads that
fail as one clear line (truncated, directories, multi-part), and G-buffer files."""

import os
import re
import stat

import numpy as np
import pytest

from ssskit.errors import GBufferError, OutputError
from ssskit.io import EXR_MAGIC, atomic_output, check_distinct, read_exr, save_image, write_exr, write_text
from ssskit.screenspace import Camera, GBuffer, load_gbuffer


@pytest.fixture
def umask():
    """Set the process umask for one test (restored after)."""
    saved = os.umask(0o022)
    os.umask(saved)
    yield lambda mask: os.umask(mask)
    os.umask(saved)


def _gbuffer(h=12, w=16):
    cam = Camera(w, h, 200.0, 200.0, w / 2, h / 2)
    rng = np.random.default_rng(3)
    return GBuffer(diffuse=rng.random((h, w, 3)).astype(np.float32), albedo=np.full((h, w, 3), 0.5, np.float32),
                   depth=np.full((h, w), 400.0, np.float32), profile_id=np.ones((h, w), np.uint32), camera=cam,
                   materials=("Skin1",), meta={"scene": "test"})


# ---- atomic writes -------------------------------------------------------------------------------

@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_written_files_follow_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    for name, write in (("a.txt", lambda p: write_text(p, "x")),
                        ("b.png", lambda p: save_image(p, np.ones((4, 4, 3)))),
                        ("c.exr", lambda p: save_image(p, np.ones((4, 4, 3))))):
        write(tmp_path / name)
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode, name


def test_atomic_output_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError):
        with atomic_output(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_atomic_output_refuses_a_directory(tmp_path):
    (tmp_path / "x.png").mkdir()
    with pytest.raises(OutputError, match="is a directory"):
        save_image(tmp_path / "x.png", np.ones((4, 4, 3)))


# ---- outputs over inputs -------------------------------------------------------------------------

def test_check_distinct(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    src = tmp_path / "g.exr"
    src.write_bytes(b"x")
    (tmp_path / "sub").mkdir()
    os.symlink(src, tmp_path / "link.exr")
    os.link(src, tmp_path / "hard.exr")
    for same in ("g.exr", str(src), "sub/../g.exr", tmp_path / "link.exr", "hard.exr"):
        with pytest.raises(OutputError, match="would overwrite the input"):
            check_distinct(same, "slab", None, src)
    check_distinct("other.exr", src, "slab", None, object())  # different files, names and non-paths pass
    check_distinct(None, src)
    with pytest.raises(OutputError, match="--out 'new.png'"):  # two paths to one file not yet written
        check_distinct("new.png", tmp_path / "new.png", what="--out")


# ---- images --------------------------------------------------------------------------------------

def test_save_image_exr_layers_and_png(tmp_path):
    import OpenEXR

    img = np.random.default_rng(0).random((6, 8, 3)).astype(np.float32)
    save_image(tmp_path / "a.exr", img, {"sss": img * 2})
    with OpenEXR.File(str(tmp_path / "a.exr")) as f:
        ch = f.channels()
        np.testing.assert_array_equal(ch["RGB"].pixels, img)
        np.testing.assert_array_equal(ch["sss"].pixels, img * 2)
    save_image(tmp_path / "a.png", img)
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from PIL import Image

    from ssskit.io import tonemap

    with Image.open(tmp_path / "a.png") as png:  # 8-bit sRGB of the image tone-mapped to its 99.5th percentile
        assert png.mode == "RGB" and png.size == (8, 6)
        np.testing.assert_array_equal(np.asarray(png), np.round(255 * tonemap(img, np.percentile(img, 99.5))))
    with pytest.raises(OutputError, match=".exr or .png"):
        save_image(tmp_path / "a.tif", img)
    with pytest.raises(OutputError, match=r"\(H, W, 3\)"):
        save_image(tmp_path / "b.png", img[..., 0])


# ---- reading OpenEXR files -----------------------------------------------------------------------

def test_read_exr_missing_directory_and_not_exr(tmp_path):
    with pytest.raises(GBufferError, match="does not exist"):
        read_exr(tmp_path / "missing.exr")
    (tmp_path / "d.exr").mkdir()
    with pytest.raises(GBufferError, match="is a directory"):
        read_exr(tmp_path / "d.exr")
    (tmp_path / "t.exr").write_text("hello")
    with pytest.raises(GBufferError, match="not an OpenEXR file"):
        read_exr(tmp_path / "t.exr")


@pytest.mark.parametrize("keep", [0.02, 0.5, 0.99])
def test_truncated_exr_is_one_line_and_silent(tmp_path, capfd, keep):
    """OpenEXR's C library prints its own error on fd 2 and the bindings a warning on stdout; neither
    may reach the user, only one GBufferError line."""
    gb = _gbuffer(64, 48)
    full = tmp_path / "g.exr"
    gb.save(full)
    data = full.read_bytes()
    cut = tmp_path / "cut.exr"
    cut.write_bytes(data[:max(int(len(data) * keep), 40)])
    capfd.readouterr()
    with pytest.raises(GBufferError) as info:
        load_gbuffer(cut)
    msg = str(info.value)
    assert "\n" not in msg and "cut.exr" in msg and "truncated or corrupt" in msg
    out, err = capfd.readouterr()
    assert out == "" and err == ""


def test_multipart_exr_reads_the_part_with_the_layers(tmp_path):
    import OpenEXR

    gb = _gbuffer()
    layers = {name: np.ascontiguousarray(getattr(gb, name)) for name in ("diffuse", "albedo", "depth", "profile_id")}
    base = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    preview = OpenEXR.Part({**base, "name": "preview"}, {"RGB": gb.diffuse}, "preview")
    main = OpenEXR.Part({**base, "name": "gbuffer", "ssskit_camera": __import__("json").dumps(gb.camera.to_dict())},
                        layers, "gbuffer")
    path = tmp_path / "multi.exr"
    with OpenEXR.File([preview, main]) as f:
        f.write(str(path))
    back = load_gbuffer(path)
    np.testing.assert_array_equal(back.diffuse, gb.diffuse)
    assert back.camera.to_dict() == gb.camera.to_dict()
    # layers spread over two parts: refused, naming the parts
    split = tmp_path / "split.exr"
    p1 = OpenEXR.Part({**base, "name": "a"}, {"diffuse": gb.diffuse, "albedo": gb.albedo}, "a")
    p2 = OpenEXR.Part({**base, "name": "b"}, {"depth": gb.depth, "profile_id": gb.profile_id}, "b")
    with OpenEXR.File([p1, p2]) as f:
        f.write(str(split))
    with pytest.raises(GBufferError, match=r"multi-part EXR and no single part holds the layers .*part 0 'a'"):
        load_gbuffer(split)


def test_write_and_read_exr_primitives(tmp_path):
    arr = np.arange(12, dtype=np.float32).reshape(3, 4)
    write_exr(tmp_path / "p.exr", {"depth": arr}, {"note": "hi"})
    assert (tmp_path / "p.exr").read_bytes()[:4] == EXR_MAGIC
    header, channels = read_exr(tmp_path / "p.exr")
    assert header["note"] == "hi"
    np.testing.assert_array_equal(channels["depth"], arr)


def test_gbuffer_save_where_no_file_can_be_made(tmp_path):
    (tmp_path / "plain").write_text("a file, not a folder")
    with pytest.raises(OutputError, match="cannot write .*plain. is not a directory"):
        _gbuffer().save(tmp_path / "plain" / "g.exr")


def test_gbuffer_file_layer_errors_name_the_file(tmp_path):
    gb = _gbuffer()
    depth = gb.depth.copy()
    depth[0, 0] = -1.0
    write_exr(tmp_path / "bad.exr", {"diffuse": gb.diffuse, "albedo": gb.albedo, "depth": depth,
                                     "profile_id": gb.profile_id},
              {"ssskit_camera": __import__("json").dumps(gb.camera.to_dict())})
    with pytest.raises(GBufferError, match=r"bad\.exr.*'depth' must lie in \(0, inf\] mm, got -1"):
        load_gbuffer(tmp_path / "bad.exr")


def test_multipart_exr_with_two_complete_parts_says_so(tmp_path):
    """Both parts hold every layer: the error said "no single part holds the layers" (false); it now
    says which parts hold them all and that the choice is ambiguous."""
    import OpenEXR

    gb = _gbuffer()
    layers = {name: np.ascontiguousarray(getattr(gb, name)) for name in ("diffuse", "albedo", "depth", "profile_id")}
    base = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    parts = [OpenEXR.Part({**base, "name": n}, layers, n) for n in ("left", "right")]
    path = tmp_path / "stereo.exr"
    with OpenEXR.File(parts) as f:
        f.write(str(path))
    with pytest.raises(GBufferError, match=r"multi-part EXR and parts 0, 1 each hold every layer diffuse, albedo, "
                                           r"depth, profile_id, so which one to read is ambiguous") as info:
        load_gbuffer(path)
    assert "no single part" not in str(info.value)


@pytest.mark.parametrize("named, fragment", [
    ('["Skin1"]', None), ("[]", "must be a non-empty list of material names, got '[]'"),
    ('["Skin1", "Skin2"]', None),
    ('{"a": 1}', "must be a non-empty list of material names"), ('[""]', "must be a non-empty list of material names")])
def test_gbuffer_header_names_a_material_for_every_id(tmp_path, named, fragment):
    """``ssskit_materials = []`` with profile id 1 was accepted (id k is the k-th name): a header that names
    materials names one at least (ssskit writes none where the G-buffer names none), and one for every id
    (GBuffer's rule: tests/screenspace/test_gbuffer.py)."""
    gb = _gbuffer()
    assert int(gb.profile_id.max()) == 1
    write_exr(tmp_path / "g.exr", {name: np.ascontiguousarray(getattr(gb, name)) for name in
                                   ("diffuse", "albedo", "depth", "profile_id")},
              {"ssskit_camera": __import__("json").dumps(gb.camera.to_dict()), "ssskit_materials": named})
    if fragment is None:
        assert load_gbuffer(tmp_path / "g.exr").materials == tuple(__import__("json").loads(named))
    else:
        with pytest.raises(GBufferError, match=re.escape(fragment)):
            load_gbuffer(tmp_path / "g.exr")


def test_gbuffer_file_naming_fewer_materials_than_its_ids_is_refused_naming_the_file(tmp_path):
    """Id 2 with one name in the header: GBuffer's rule (id k is the k-th name), the file named."""
    gb = _gbuffer()
    ids = np.ascontiguousarray(gb.profile_id)
    ids[0, 0] = 2
    write_exr(tmp_path / "g.exr", {**{name: np.ascontiguousarray(getattr(gb, name)) for name in
                                      ("diffuse", "albedo", "depth")}, "profile_id": ids},
              {"ssskit_camera": __import__("json").dumps(gb.camera.to_dict()), "ssskit_materials": '["Skin1"]'})
    with pytest.raises(GBufferError, match=re.escape(f"G-buffer {str(tmp_path / 'g.exr')!r}: layer 'profile_id' must "
                                                     "lie in [0, 1], got 2 (0 is no SSS, k the k-th of the 1 "
                                                     "materials named)")):
        load_gbuffer(tmp_path / "g.exr")


def test_staged_folder_moves_everything_or_nothing(tmp_path):
    """io.staged_folder: a failure inside leaves the target as it was and no staging folder; errors
    that name a staged path name the target instead."""
    from ssskit.io import staged_folder

    out = tmp_path / "figs"
    with pytest.raises(OutputError, match=re.escape(f"cannot write {str(out / 'b.png')!r}")):
        with staged_folder(out) as stage:
            (stage / "a.png").write_bytes(b"a")
            with atomic_output(stage / "b.png") as tmp:
                raise OSError(28, "No space left on device")
    assert list(tmp_path.iterdir()) == []
    with staged_folder(out) as stage:
        (stage / "sub").mkdir()
        (stage / "sub" / "c.txt").write_text("c")
    assert (out / "sub" / "c.txt").read_text() == "c" and sorted(p.name for p in tmp_path.iterdir()) == ["figs"]


def test_heartbeat_fills_a_silence_in_plain_lines(capsys, monkeypatch):
    """A step that reports nothing for longer than the heartbeat's interval gets a line naming it (stderr,
    plain lines: capsys is no terminal); the block's own lines are kept."""
    import time

    from ssskit.io import heartbeat, say

    with heartbeat(0.6):
        say("a long step")
        time.sleep(2.0)
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "  a long step"
    assert len(err) >= 2 and all(line.startswith("  ... still working, ") and line.endswith(": a long step")
                                 for line in err[1:])


DEEP = {".json": "[" * 100_000 + "]" * 100_000, ".toml": "a = " + "[" * 100_000 + "]" * 100_000}


@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_a_document_nested_too_deeply_is_malformed_in_every_reader(tmp_path, suffix):
    """A 100,000-deep nested JSON (or TOML) raised RecursionError from the parsers (a traceback from the CLI);
    every reader of a user's TOML/JSON file (material, settings, scene) now calls it malformed."""
    from ssskit.errors import MaterialError, SceneError, SettingsError
    from ssskit.io import parse_document
    from ssskit.materials import load_material
    from ssskit.pipeline.settings import RenderSettings
    from ssskit.scenes import resolve_scene

    with pytest.raises(ValueError, match="nested too deeply"):
        parse_document(DEEP[suffix], suffix)
    path = tmp_path / f"deep{suffix}"
    path.write_text(DEEP[suffix])
    with pytest.raises(MaterialError, match="malformed material file .* nested too deeply"):
        load_material(path)
    with pytest.raises(SettingsError, match="malformed settings file .* nested too deeply"):
        RenderSettings.load(path)
    if suffix == ".toml":
        with pytest.raises(SceneError, match="malformed scene file .* nested too deeply"):
            resolve_scene(str(path))


@pytest.mark.skipif(not os.path.exists("/proc/self/mem"), reason="needs Linux's /proc/self/mem (a file whose read fails)")
def test_an_input_that_fails_to_read_is_one_error_naming_it():
    """A regular file whose read fails (Linux's /proc/self/mem at offset 0: EIO) is the reader's one error in the
    OS's words, as a write that fails is (io._failing)."""
    from ssskit.errors import SettingsError
    from ssskit.io import read_input

    with pytest.raises(SettingsError, match=r"^cannot read settings file '/proc/self/mem': Input/output error$"):
        read_input("/proc/self/mem", "settings file", SettingsError)
