"""The cache's folders: one per kind, and no other path."""

import pytest

from ssskit.cache import KINDS, cache_dir, cache_root


@pytest.mark.parametrize("kind", ["../../etc", "..", "mcml/../..", "/tmp", "MCML", ""])
def test_cache_dir_refuses_a_kind_it_does_not_know(kind, monkeypatch, tmp_path):
    """The Literal type tells mypy the kinds; a caller's string is checked at run time too, so that no kind names a
    path outside the cache root (cache_dir('../../etc') returned one)."""
    monkeypatch.setenv("SSSKIT_CACHE_DIR", str(tmp_path))
    with pytest.raises(ValueError, match="cache kind must be one of mcml, reference"):
        cache_dir(kind)  # type: ignore[arg-type]
    assert [cache_dir(k) for k in KINDS] == [cache_root() / k for k in KINDS]
    assert all(cache_dir(k).parent == tmp_path for k in KINDS)
