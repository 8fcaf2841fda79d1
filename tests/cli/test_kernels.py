"""``ssskit kernel``, ``ssskit evaluate`` and ``ssskit figures``."""

import json

import pytest


def test_kernel_jimenez_json(run):
    code, out, _ = run("kernel", "--method", "jimenez2012", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["offsets"][0] == 0.0 and len(data["weights"]) == 11
    assert data["weights"][0] == pytest.approx([0.560479, 0.669086, 0.784728], abs=5e-7)


def test_kernel_tabulated_out(run, tmp_path):
    from ssskit.kernels import load_kernel

    out_file = tmp_path / "k.npz"
    code, out, _ = run("kernel", "--material", "skin1", "--model", "dipole", "--method", "svd", "--rank", "2",
                       "--size", "51", "--json", "--out", out_file)
    assert code == 0
    data = json.loads(out)
    assert len(data["x_mm"]) == 51 and len(data["channels"]["R"]["components"]) == 2
    assert load_kernel(out_file).rank == 2
    # the parameter inline gives the same kernel
    code, inline, _ = run("kernel", "--material", "skin1", "--model", "dipole", "--method", "svd:2", "--size", "51",
                          "--json")
    assert code == 0 and json.loads(inline) == data


def test_kernel_gaussians_count_and_deon2007_without_material(run):
    code, out, _ = run("kernel", "--material", "skin1", "--model", "dipole", "--method", "gaussians", "--count", "3",
                       "--size", "51", "--json")
    assert code == 0 and len(json.loads(out)["channels"]["G"]["components"]) == 3
    code, out, _ = run("kernel", "--model", "deon2007", "--method", "svd:1", "--size", "51", "--json")
    assert code == 0 and json.loads(out)["material"] is None


def test_evaluate_json(run):
    code, out, _ = run("evaluate", "--material", "skin1", "--model", "dipole", "--signal", "edge",
                       "--methods", "preintegrated,svd:1", "--size", "64", "--json")
    assert code == 0
    data = json.loads(out)
    assert set(data) == {"preintegrated", "svd:1"}
    for r in data.values():
        assert {"rmse", "relative_rmse", "psnr", "convolutions_1d", "ssim", "flip"} <= set(r)
    assert data["preintegrated"]["psnr"] is None or data["preintegrated"]["psnr"] > 200


def test_figures(run, tmp_path):
    code, out, _ = run("figures", "fig2", "fig5", "--model", "dipole", "--out", tmp_path / "new" / "figs")
    assert code == 0
    folder = tmp_path / "new" / "figs"
    assert (folder / "fig2_singular_values.png").stat().st_size > 1000
    assert (folder / "fig5_slices.png").exists()
    assert sorted(out.split()) == sorted(str(p) for p in folder.iterdir())
