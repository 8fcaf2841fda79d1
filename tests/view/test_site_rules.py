"""The viewer's request rules in Python (no browser): MaterialRequest's messages, page_file's name check, and
that neither importing the viewer nor making a request imports the pipeline (the view's start stays light)."""

import subprocess
import sys

import pytest

from ssskit.errors import SsskitError
from ssskit.view.site import PAGE_FILES, MaterialRequest, page_file


@pytest.mark.parametrize("kwargs, message", [
    ({"taps": 19}, "taps must be one of 5, 7, 9, 11, 13, 15, 17, 21, 25, got 19"),  # the int, not '19'
    ({"taps": 4}, "taps must be one of 5, 7, 9, 11, 13, 15, 17, 21, 25, got 4"),
    ({"taps": "7"}, "taps must be one of 5, 7, 9, 11, 13, 15, 17, 21, 25, got '7'"),
    ({"taps": 7.0}, "got 7.0"),
    ({"taps": True}, "got True"),
    ({"jitter": 2}, r"jitter must lie in [0, 1], got 2 (a fraction of the kernel size)"),
    ({"jitter": float("nan")}, "(a fraction of the kernel size)"),
    ({"kernel": 5}, "unknown kernel method '5'"),
    ({"kernel": ["svd"]}, "unknown kernel method \"['svd']\""),
    ({"kernel": "nope:3"}, "unknown kernel method 'nope'"),
])
def test_a_material_requests_refusals_name_the_value_as_given(kwargs, message):
    with pytest.raises(SsskitError) as info:
        MaterialRequest("skin1", **kwargs)
    assert message in str(info.value)


@pytest.mark.parametrize("name", ["../__init__.py", "../site.py", "/etc/passwd", "data.js", ""])
def test_page_file_reads_only_the_pages_files(name):
    """page_file is public: a name outside PAGE_FILES (a path into the package) is refused, not read."""
    with pytest.raises(SsskitError, match="page file must be one of index.html, viewer.js, viewer.css"):
        page_file(name)
    assert all(page_file(n) for n in PAGE_FILES)


def test_the_viewer_and_its_requests_import_no_pipeline():
    """``import ssskit.view.site`` and a checked MaterialRequest (what ``ssskit view`` does before its first
    refusal) do not import the pipeline: importing it took 0.2 s of every start (before the request's rules were
    declared with ``like(RenderSettings, ...)``, and again now, the kernel spec's check imports only ssskit.kernels)."""
    code = ("import sys; from ssskit.view.site import MaterialRequest; MaterialRequest('skin1', kernel='svd:2', "
            "taps=9, jitter=0.3); print(sorted(m for m in ('ssskit.pipeline', 'ssskit.pipeline.settings') if m in sys.modules))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.strip().splitlines()[-1] == "[]"
