"""The vocabulary of quantities (ssskit.quantities): one wording per kind of refusal, naming the actual and the
expected value, raised as the caller's area error; settings fields declared with it (ssskit.settings.setting)."""

from __future__ import annotations

import dataclasses
import doctest
import math

import numpy as np
import pytest

import ssskit.quantities as q
from ssskit.errors import MaterialError, PassError, SettingsError, SsskitError
from ssskit.settings import Settings, setting


def test_doctests():
    assert doctest.testmod(q).failed == 0


@pytest.mark.parametrize("name", [n for n in q.__all__ if isinstance(getattr(q, n), q.Quantity)])
def test_every_quantity_states_its_range(name):
    quantity = getattr(q, name)
    assert quantity.lo <= quantity.hi
    if name not in ("FRACTION",):  # a plain fraction needs no reason beyond its interval
        assert quantity.reason, f"{name} has no reason for its range"


def test_range_wording_names_actual_expected_unit_and_reason():
    with pytest.raises(MaterialError) as e:
        q.MFP_MM.check(2e6, "mean free path", MaterialError)
    msg = str(e.value)
    assert msg.startswith("mean free path must lie in [1e-06, 1e+06] mm, got 2e+06 (1 nm to 1 km")


def test_nan_is_out_of_range_and_inf_only_where_the_range_holds_it():
    with pytest.raises(SsskitError, match=r"^g must lie in \(-1, 1\), got nan"):
        q.ANISOTROPY.check(math.nan)
    with pytest.raises(SsskitError, match=r"^sigma_a must lie in \[0, inf\) mm\^-1, got inf"):
        q.COEFFICIENT.check(math.inf, "sigma_a")
    assert q.THICKNESS_MM.check(math.inf) == math.inf  # a semi-infinite layer


def test_types_refused_in_one_wording():
    with pytest.raises(SettingsError, match=r"^spp must be an integer, got True$"):
        q.SPP.check(True, "spp", SettingsError)
    with pytest.raises(SettingsError, match=r"^spp must be an integer, got 1.5$"):
        q.SPP.check(1.5, "spp", SettingsError)
    with pytest.raises(SettingsError, match=r"^eta must be a number, got '1.3'$"):
        q.ETA.check("1.3", "eta", SettingsError)
    with pytest.raises(SettingsError, match=r"^taps must be an odd integer, got 8$"):
        q.TAPS.check(8, "taps", SettingsError)
    assert q.TAPS.check(np.int64(7)) == 7 and type(q.TAPS.check(np.int64(7))) is int


def test_burley_albedo_refuses_zero_and_names_why():
    """Xie 2020 Eq. 5 / Burley 2015: A in (0, 1]; A = 0 gives R(r) = 0 (module docstring of profiles.domain)."""
    assert q.BURLEY_ALBEDO.check_rgb(0.5) == (0.5, 0.5, 0.5)
    assert q.BURLEY_ALBEDO.check_rgb(np.array(0.5)) == (0.5, 0.5, 0.5)  # a 0-d array is one number, as in check()
    assert q.BURLEY_ALBEDO.check(1.0) == 1.0
    with pytest.raises(PassError, match=r"albedo must lie in \(0, 1\], got \(0.5, 0, 1\) \(a reflectance; A = 0"):
        q.BURLEY_ALBEDO.check_rgb([0.5, 0, 1], "albedo", PassError)
    with pytest.raises(PassError, match=r"albedo must be a number or three \[R, G, B\], got \(1, 2\)"):
        q.BURLEY_ALBEDO.check_rgb([1, 2], "albedo", PassError)


def test_arrays_finite_wording_counts_and_locates():
    img = np.ones((2, 3))
    img[1, 2] = np.nan
    with pytest.raises(SsskitError, match=r"^diffuse must be finite, got NaN or inf in 1 of 6 pixels, the first at "
                                          r"\(1, 2\)$"):
        q.check_finite(img, "diffuse", where="pixels")
    with pytest.raises(SsskitError, match=r"^radii must lie in \[0, inf\) mm, got -1 in 1 of 3 values"):
        q.Quantity("radii", 0.0, math.inf, "mm", hi_open=True).check_array([0, 1, -1])
    assert q.check_finite(np.arange(3), "ints") is not None


def test_choice_and_flag():
    assert q.Choice("sampler", ("exact", "xie")).check(" XIE ") == "xie"
    with pytest.raises(SettingsError, match=r"^sampler must be one of exact, xie, got 'golub'$"):
        q.Choice("sampler", lambda: ("exact", "xie")).check("golub", error=SettingsError)
    with pytest.raises(SsskitError, match=r"^mips must be true or false, got 'yes'$"):
        q.Flag("mips").check("yes")


@dataclasses.dataclass(frozen=True)
class _Toy(Settings):
    mode: str = setting(q.Choice("mode", ("a", "b")), "a")
    knob: float = setting(q.FRACTION, 0.5, applies=("mode", ("b",)))
    spp: int = setting(q.SPP, 4)


def test_declared_fields_are_checked_and_canonical():
    t = _Toy(mode="B", knob=1, spp=np.int32(8))
    assert (t.mode, t.knob, t.spp) == ("b", 1.0, 8) and type(t.spp) is int
    with pytest.raises(SettingsError, match=r"^spp must lie in \[1, 4096\], got 0"):
        _Toy(spp=0)


def test_an_option_given_but_unused_is_refused_once():
    assert _Toy(knob=0.5).knob == 0.5  # at its default: not given
    with pytest.raises(SettingsError, match=r"^knob applies to mode b, not mode a$"):
        _Toy(knob=0.25)
    with pytest.raises(SettingsError, match=r"^x, y apply to sampler xie, not sampler exact$"):
        q.refuse_unused(["x", "y"], "sampler", ["xie"], "exact", SettingsError)
    q.refuse_unused([], "sampler", ["xie"], "exact")  # nothing given: nothing refused


# --- vocab-b: arrays, tables and types in the same wordings ---------------------------------------------------

def test_check_shape_names_the_expected_shape_kind_and_what_came():
    a = q.check_shape([[1, 2, 3]], "diffuse", ("H", 3))
    assert a.shape == (1, 3) and a.dtype.kind == "i"
    with pytest.raises(PassError, match=r"^diffuse must be a real array of shape \(4, 4, 3\), got shape \(4, 4\) "
                                        r"float64$"):
        q.check_shape(np.zeros((4, 4)), "diffuse", (4, 4, 3), PassError)
    with pytest.raises(PassError, match=r"^slots must be an integer array of shape \(H, W\), got shape \(2, 2\) "
                                        r"float32$"):
        q.check_shape(np.zeros((2, 2), np.float32), "slots", ("H", "W"), PassError, "iu")
    with pytest.raises(SsskitError, match=r"^v must be finite, got NaN or inf in 1 of 3 values, the first at 1$"):
        q.check_shape([0.0, math.inf, 1.0], "v", (3,), finite=True)
    assert q.check_shape(np.zeros((0, 0)), "empty", ("H", "W"), kinds="iu").size == 0  # an empty image passes
    assert q.check_shape([1, 2], "x", (2,), dtype=np.float32).dtype == np.float32


def test_check_keys_and_fields_read_a_table_by_its_declared_quantities():
    table = {"distance": 3, "size": 0.5}
    assert q.check_keys(table, "light 'key'", {"distance", "size"}, ("distance",)) is table
    with pytest.raises(SsskitError, match=r"^light 'key': unknown key\(s\) colour \(known: distance, size\)$"):
        q.check_keys({"colour": 1}, "light 'key'", {"distance", "size"})
    with pytest.raises(SsskitError, match=r"^light 'key': missing distance$"):
        q.check_keys({}, "light 'key'", {"distance"}, ("distance",))
    with pytest.raises(SsskitError, match=r"^light 'key' must be a table, got 5$"):
        q.check_keys(5, "light 'key'")
    fields = {"size": q.FRACTION, "g": q.ANISOTROPY, "colour": q.REFLECTANCE}
    assert q.check_fields({"size": 0.5, "colour": 0.2}, fields, "light", rgb=("colour",)) == {
        "size": 0.5, "colour": (0.2, 0.2, 0.2)}  # absent keys are left to the caller's defaults
    with pytest.raises(MaterialError, match=r"^light: g must lie in \(-1, 1\), got 1 "):
        q.check_fields({"g": 1.0}, fields, "light", MaterialError)


def test_check_instance_names_the_types():
    assert q.check_instance(None, int, "n", optional=True) is None
    with pytest.raises(SettingsError, match=r"^settings must be int or float, got str$"):
        q.check_instance("1", (int, float), "settings", SettingsError)


def test_checks_declares_a_functions_argument_rules_at_its_signature():
    @q.checks(MaterialError, spp=q.SPP, kind=(q.Choice("kind", ("mfp", "dmfp")), "distance kind"),
              albedo=q.rgb(q.REFLECTANCE), fraction=q.FRACTION)
    def f(spp: int, kind: str = "dmfp", albedo: object = 0.5, fraction: float | None = None) -> tuple:
        return spp, kind, albedo, fraction

    # the body gets the checked values: an int, a choice's canonical spelling, three floats; None where optional
    assert f(np.int64(8), "MFP") == (8, "mfp", (0.5, 0.5, 0.5), None)
    assert f(1, fraction=0.25)[3] == 0.25
    with pytest.raises(MaterialError, match=r"^spp must lie in \[1, 4096\], got 0 "):
        f(0)  # under the argument's name, in the caller's error
    with pytest.raises(MaterialError, match=r"^distance kind must be one of mfp, dmfp, got 'radius'$"):
        f(8, kind="radius")  # under the name given with the rule
    with pytest.raises(MaterialError, match=r"^albedo must lie in \[0, 1\], got \(0.5, 2, 0.5\)"):
        f(8, albedo=(0.5, 2.0, 0.5))
    with pytest.raises(MaterialError, match=r"^spp must be an integer, got None$"):
        f(None)  # None passes only where it is the default
    with pytest.raises(TypeError):
        f()  # a missing argument stays Python's own error
