"""The .bn kernel file: its byte layout read with a reader written from the public loaders, round trips
to float32 precision, and every malformed file refused with a reason."""

import struct

import numpy as np
import pytest

from ssskit.errors import KernelError, OutputError
from ssskit.export import bn_bytes, load_bn, read_bn, save_bn
from ssskit.kernels import build_kernel
from ssskit.kernels.jimenez2012 import kernel_jimenez2012
from ssskit.profiles import profile_for_material


@pytest.fixture(scope="module")
def kernel():
    return build_kernel("preintegrated", profile_for_material("skin1", "dipole"), n=101)


def _public_reader(path):
    """As the public 2015-style loaders read it: a float count (floored), then that many floats,
    four per sample (r, g, b, x)."""
    raw = path.read_bytes()
    (count,) = struct.unpack("<f", raw[:4])
    fc = int(np.floor(count))
    vals = struct.unpack(f"<{fc}f", raw[4:4 + 4 * fc])
    return [vals[i:i + 4] for i in range(0, fc, 4)]


def test_layout(kernel, tmp_path):
    path = tmp_path / "k.bn"
    save_bn(kernel, path)
    recs = _public_reader(path)
    assert path.stat().st_size == 4 + 16 * kernel.n
    assert len(recs) == kernel.n
    x = np.array([r[3] for r in recs])
    np.testing.assert_array_equal(x, kernel.x_mm.astype(np.float32))
    assert x[kernel.n // 2] == 0.0 and x[0] == -x[-1]
    np.testing.assert_array_equal(np.array([r[:3] for r in recs]), kernel.components[:, 0].T.astype(np.float32))


def test_roundtrip(kernel, tmp_path):
    path = tmp_path / "k.bn"
    save_bn(kernel, path)
    back = load_bn(path)
    assert back.rank == 1 and back.n == kernel.n
    assert back.cell_mm == pytest.approx(kernel.cell_mm, rel=1e-6)
    np.testing.assert_allclose(back.components, kernel.components, rtol=2.0**-24, atol=0)
    np.testing.assert_allclose(back.total(), kernel.total(), rtol=1e-6)


def _write(path, floats):
    path.write_bytes(np.asarray(floats, dtype="<f4").tobytes())


def test_bad_files(kernel, tmp_path):
    p = tmp_path / "bad.bn"
    p.write_bytes(b"abc")
    with pytest.raises(KernelError, match="not a .bn kernel"):
        read_bn(p)
    _write(p, [12, 1, 1, 1, -1, 1, 1, 1, 1])  # announces 12, holds 8
    with pytest.raises(KernelError, match="announces 12"):
        read_bn(p)
    _write(p, [12, 1, 1, 1, -1, 1, 1, 1, 0.2, 1, 1, 1, 1])  # uneven spacing
    with pytest.raises(KernelError, match="uniform"):
        read_bn(p)
    _write(p, [12, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 2])  # 0..2: not symmetric
    with pytest.raises(KernelError, match="symmetric"):
        read_bn(p)
    _write(p, [8, 1, 1, 1, -0.5, 1, 1, 1, 0.5])  # symmetric, even: raw samples only
    x, rgb = read_bn(p)
    assert x.tolist() == [-0.5, 0.5] and rgb.shape == (2, 3)
    with pytest.raises(KernelError, match="centre sample"):
        load_bn(p)
    with pytest.raises(KernelError, match="does not exist"):
        read_bn(tmp_path / "nope.bn")


def test_refused_kernels(tmp_path):
    skin = profile_for_material("skin1", "dipole")
    with pytest.raises(KernelError, match="list of taps"):
        save_bn(kernel_jimenez2012(11), tmp_path / "t.bn")
    with pytest.raises(KernelError, match="rank 2"):
        save_bn(build_kernel("svd", skin, rank=2, n=51), tmp_path / "s.bn")
    with pytest.raises(OutputError, match="must end in .bn"):
        save_bn(build_kernel("preintegrated", skin, n=51), tmp_path / "s.bin")
    with pytest.raises(KernelError, match="uniform"):
        bn_bytes([0.0, 1.0, 3.0], np.ones((3, 3)))
    assert not list(tmp_path.iterdir())


def test_crop_to_support(kernel, tmp_path):
    """--format bn crops the grid to 99.9 % of each channel's mass: the loaders' tap range is the file's extent."""
    path = tmp_path / "c.bn"
    save_bn(kernel, path, support=0.999)
    x, rgb = read_bn(path)
    assert x.size < kernel.n and x.size % 2 == kernel.n % 2 and x[0] == -x[-1]
    full = np.abs(kernel.components[:, 0, :]).sum(axis=1)
    assert np.all(np.abs(rgb).sum(axis=0) >= 0.999 * full * (1 - 1e-6))
    # one cell fewer on each side would hold less than 99.9 % in some channel
    assert np.any(np.abs(rgb[1:-1]).sum(axis=0) < 0.999 * full)
