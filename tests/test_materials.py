import json
import math

import pytest

from ssskit.errors import MaterialError
from ssskit.materials import (
    ARTIST_PRESETS,
    MATERIALS,
    Material,
    get_material,
    load_material,
    material_from_dict,
)


def test_eleven_presets_from_supplement_section_g():
    assert MATERIALS.names() == [
        "Apple", "Chicken1", "Chicken2", "Cream", "Ketchup", "Marble",
        "Potato", "Skimmilk", "Skin1", "Skin2", "Wholemilk",
    ]


@pytest.mark.parametrize(
    "name, sigma_a, sigma_s, eta",
    [  # printed values, supplement G.1, G.5, G.6, G.9, G.11
        ("Apple", (0.0030, 0.0034, 0.0460), (2.2900, 2.3900, 1.9700), 1.3),
        ("Ketchup", (0.0610, 0.9700, 1.4500), (0.1800, 0.0700, 0.0300), 1.3),
        ("Marble", (0.0021, 0.0041, 0.0071), (2.1900, 2.6200, 3.0000), 1.5),
        ("Skin1", (0.0320, 0.1700, 0.4800), (0.7400, 0.8800, 1.0100), 1.3),
        ("Wholemilk", (0.0011, 0.0024, 0.0140), (2.5500, 3.2100, 3.7700), 1.3),
    ],
)
def test_supplement_section_g_values(name, sigma_a, sigma_s, eta):
    m = MATERIALS.get(name)
    assert m.sigma_a == sigma_a and m.sigma_s == sigma_s and m.eta == eta
    assert m.g == (0.0, 0.0, 0.0) and m.is_semi_infinite


def test_names_are_case_insensitive():
    assert get_material("sKiN1") is MATERIALS.get("Skin1")
    assert "WHOLEMILK" in MATERIALS


def test_table2_artist_presets():
    close = ARTIST_PRESETS.get("Close Fit")
    assert close.sigma_near == (0.034, 0.029, 0.016) and close.sigma_far == (1.0, 0.48, 0.2) and close.weight == 0.37
    prod = ARTIST_PRESETS.get("production")
    assert prod.sigma_near == (0.25, 0.08, 0.02) and prod.sigma_far == (1.0, 0.3, 0.05) and prod.weight == 0.6


def test_derived_quantities_skin1_red():
    m = MATERIALS.get("skin1")
    assert m.sigma_t[0] == pytest.approx(0.772)
    assert m.albedo[0] == pytest.approx(0.74 / 0.772)
    assert m.mfp_mm[0] == pytest.approx(1 / 0.772)
    assert m.sigma_tr[0] == pytest.approx(math.sqrt(3 * 0.032 * 0.772))
    g = Material("aniso", 0.1, 1.0, g=0.5)
    assert g.sigma_s_reduced == (0.5, 0.5, 0.5)
    assert g.albedo_reduced[0] == pytest.approx(0.5 / 0.6)


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        (dict(sigma_a=-0.1, sigma_s=1.0), "sigma_a must lie in [0, inf) mm^-1, got -0.1 in 3 of 3 channels"),
        (dict(sigma_a=0.1, sigma_s=(1.0, -1.0, 1.0)), "sigma_s must lie in [0, inf) mm^-1, got -1 in 1 of 3 channels"),
        (dict(sigma_a=0.1, sigma_s=1.0, eta=0.9), "eta must lie in [1, inf), got 0.9"),
        (dict(sigma_a=0.1, sigma_s=1.0, g=1.0), "g must lie in (-1, 1), got 1 in 3 of 3 channels"),
        (dict(sigma_a=0.1, sigma_s=1.0, g=-1.2), "g must lie in (-1, 1), got -1.2"),
        (dict(sigma_a=(0.1, 0.2), sigma_s=1.0), "sigma_a must be a number or a list of 3 numbers (R, G, B), got 2 values"),
        (dict(sigma_a=float("nan"), sigma_s=1.0), "sigma_a must be finite, got NaN or inf in 3 of 3 channels"),
        (dict(sigma_a=0.0, sigma_s=0.0), "sigma_a + sigma_s must lie in (0, inf) mm^-1, got 0"),
        (dict(sigma_a=0.1, sigma_s=1.0, thickness_mm=0), "thickness_mm must lie in (0, inf] mm, got 0"),
    ],
)
def test_invalid_coefficients_raise(kwargs, fragment):
    with pytest.raises(MaterialError, match=None) as info:
        Material("bad", **kwargs)
    assert fragment in str(info.value)


def test_unknown_name_lists_known():
    with pytest.raises(MaterialError, match="unknown material 'jade'.*Skin1"):
        get_material("jade")


def test_toml_and_json_roundtrip(tmp_path):
    toml = tmp_path / "mine.toml"
    toml.write_text('name = "mine"\nsigma_a = [0.032, 0.17, 0.48]\nsigma_s = [0.74, 0.88, 1.01]\neta = 1.3\n')
    m = load_material(toml)
    assert m.sigma_a == MATERIALS.get("skin1").sigma_a and m.name == "mine"
    js = tmp_path / "cm.json"
    js.write_text(json.dumps({"sigma_a": 0.32, "sigma_s": 7.4, "unit": "cm", "thickness_mm": 2}))
    m2 = get_material(str(js))
    assert m2.sigma_a == pytest.approx((0.032,) * 3) and m2.thickness_mm == 20.0 and m2.name == "cm"
    again = material_from_dict(m.to_dict())
    assert again == m


@pytest.mark.parametrize(
    "text, suffix, fragment",
    [
        ("sigma_a = [1, 2", ".toml", "malformed"),
        ('{"sigma_a": 1}', ".json", "material: missing sigma_s"),
        ('{"sigma_a": 1, "sigma_s": 1, "colour": 2}', ".json", "material: unknown key(s) colour"),
        ('{"sigma_a": 1, "sigma_s": 1, "eta": 0.5}', ".json", "eta must lie in [1, inf), got 0.5"),
        ("[1, 2]", ".json", "material must be a table, got (1, 2)"),
        ("sigma_a: 1", ".yaml", "must end in .toml or .json"),
    ],
)
def test_malformed_files(tmp_path, text, suffix, fragment):
    p = tmp_path / f"m{suffix}"
    p.write_text(text)
    with pytest.raises(MaterialError) as info:
        load_material(p)
    assert fragment in str(info.value)


def test_missing_file():
    with pytest.raises(MaterialError, match="material file .*file.toml. does not exist"):
        load_material("/nonexistent/file.toml")


# ---- bad values in material files: one clear line naming the key ---------------------------------

_BAD_VALUES = [  # TOML literals, and how the message describes them
    ('"abc"', "the string 'abc'"),
    ('"0.1"', "the string '0.1' (write numbers without quotes)"),
    ('"123"', "the string '123'"),  # once silently read as [1, 2, 3]
    ("{r = 1}", "a table/object"),
    ("true", "the boolean true"),
    ('["0.1", 0.2, 0.3]', ""),  # strings inside a list are refused too
    ("[0.1, true, 0.3]", ""),
]
_GOOD = {"sigma_a": "0.1", "sigma_s": "1.0", "g": "0.0", "eta": "1.3", "thickness_mm": "2.0", "eta_ambient": "1.0"}


def _toml(values):
    return "".join(f"{k} = {v}\n" for k, v in values.items())


@pytest.mark.parametrize("key", list(_GOOD))
@pytest.mark.parametrize("literal, described", _BAD_VALUES)
def test_file_values_must_be_numbers(tmp_path, key, literal, described):
    p = tmp_path / "bad.toml"
    p.write_text(_toml({**_GOOD, key: literal}))
    with pytest.raises(MaterialError) as info:
        get_material(str(p))
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{str(p)!r}: {key} must ")
    assert described in msg


@pytest.mark.parametrize("key", ["eta_above", "eta_below"])
@pytest.mark.parametrize("literal, described", _BAD_VALUES)
def test_layered_file_ambient_indices_must_be_numbers(tmp_path, key, literal, described):
    p = tmp_path / "layered.toml"
    p.write_text(f"{key} = {literal}\n[[layers]]\nsigma_a = 0.1\nsigma_s = 1.0\n")
    with pytest.raises(MaterialError) as info:
        get_material(str(p))
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{str(p)!r}: {key} must be a number, got ") and described in msg


def test_layer_values_must_be_numbers(tmp_path):
    p = tmp_path / "layered.toml"
    p.write_text('[[layers]]\nsigma_a = 0.1\nsigma_s = 1.0\nthickness_mm = 1\n[[layers]]\nsigma_a = "0.1"\nsigma_s = 1\n')
    with pytest.raises(MaterialError, match=r"layer 2: sigma_a must be a number or a list of 3 numbers"):
        get_material(str(p))


def test_thickness_in_cm_must_be_a_number(tmp_path):
    p = tmp_path / "cm.json"
    p.write_text(json.dumps({"sigma_a": 1, "sigma_s": 10, "unit": "cm", "thickness_mm": "0.2"}))
    with pytest.raises(MaterialError, match="thickness_mm must be a number, got the string '0.2'"):
        get_material(str(p))


def test_numbers_from_code_still_accepted():
    import numpy as np

    m = Material("np", np.array([0.1, 0.2, 0.3]), np.float32(1.0), eta=np.float64(1.4), thickness_mm=np.int64(2))
    assert m.sigma_a == (0.1, 0.2, 0.3) and m.sigma_s == (1.0, 1.0, 1.0) and m.thickness_mm == 2.0
    with pytest.raises(MaterialError, match="sigma_a must be a number or a list of 3 numbers"):
        Material("str", "0.1", 1.0)  # type: ignore[arg-type]


@pytest.mark.parametrize("name", ["", "   "])
def test_empty_material_name(name):
    with pytest.raises(MaterialError, match="^the material name is empty; give a preset name"):
        get_material(name)


def test_directory_as_material_file(tmp_path):
    d = tmp_path / "mats.toml"
    d.mkdir()
    for arg in (str(tmp_path), str(d)):
        with pytest.raises(MaterialError, match=r"is a directory, not a file"):
            get_material(arg)
