"""The archive as researchers read it: h5py, xarray (h5netcdf), numpy recomputation."""
import pathlib
import subprocess

import h5py
import numpy as np
import pytest
import xarray as xr

ROOT = pathlib.Path(__file__).resolve().parents[2]

PROVENANCE = [
    "stage_kind", "cache_version", "params_yaml", "params_hash", "inputs", "seed", "rng_scheme",
    "laydown_version", "git_commit", "git_dirty", "rustc_version", "hdf5_version", "host", "threads",
    "command_line", "start_utc", "end_utc", "wall_seconds", "cpu_seconds", "status", "fingerprint",
    "content_hash", "dataset_hashes",
]


def version_groups(f):
    for stage in f:
        for name, obj in f[stage].items():
            if name.startswith("v"):
                yield f"/{stage}/{name}", obj


def current_group(archive, stage):
    """The group of a stage's current version, named by the `current` attribute of /<stage>."""
    with h5py.File(archive, "r") as f:
        return f"/{stage}/{f[stage].attrs['current']}"


def test_root_attributes_follow_cf(quickstart_archive):
    with h5py.File(quickstart_archive, "r") as f:
        assert f.attrs["Conventions"] == "CF-1.8"
        assert f.attrs["layout_version"] == 2
        assert len(f.attrs["history"].splitlines()) >= 1


def test_every_version_has_full_provenance_and_units(quickstart_archive):
    with h5py.File(quickstart_archive, "r") as f:
        groups = list(version_groups(f))
        assert groups
        for path, g in groups:
            for key in PROVENANCE:
                assert key in g.attrs, f"{path} lacks {key}"
            assert g.attrs["status"] == "complete"
            for name, ds in g.items():
                assert "long_name" in ds.attrs, f"{path}/{name} lacks long_name"
                if ds.dtype.kind == "f":
                    assert "units" in ds.attrs, f"{path}/{name} lacks units"


def test_xarray_sees_named_dimensions(quickstart_archive):
    with h5py.File(quickstart_archive, "r") as f:
        paths = [p for p, _ in version_groups(f)]
    for path in paths:
        ds = xr.open_dataset(quickstart_archive, group=path, engine="h5netcdf")
        assert not any(d.startswith("phony_dim") for d in ds.sizes), (path, dict(ds.sizes))
        # Sweep-stacked stages have a `point` dimension; the image stage stacks samples.
        assert "point" in ds.sizes or "sample" in ds.sizes, (path, dict(ds.sizes))
        ds.close()
    ideal = xr.open_dataset(quickstart_archive, group=current_group(quickstart_archive, "ideal"), engine="h5netcdf")
    assert ideal["energy_spectrum"].dims == ("point", "fibre", "bin")
    assert "arc_length" in ideal["curvature"].coords and "angular_frequency" in ideal["energy_spectrum"].coords
    np.testing.assert_allclose(ideal["arc_length"].values[0, 1], ideal["sample_spacing"].values[0])
    fibre = xr.open_dataset(quickstart_archive, group=current_group(quickstart_archive, "fibre"), engine="h5netcdf")
    assert fibre["positions"].dims == ("point", "replicate", "node", "xyz")
    assert list(fibre["xyz"].values) == ["x", "y", "z"]
    assert fibre["positions"].attrs["units"] == "m"
    tree = xr.open_datatree(quickstart_archive, engine="h5netcdf")
    assert {"fibre", "spectra", "ideal"} <= set(tree.children)


def test_current_is_an_attribute_and_no_group_appears_twice(quickstart_archive):
    """Each stage names its current version; open_datatree sees every version group once."""
    tree = xr.open_datatree(quickstart_archive, engine="h5netcdf")
    with h5py.File(quickstart_archive, "r") as f:
        stages = list(f)
        for stage in stages:
            node = tree[stage]
            versions = sorted(node.children)
            # Only v<N> groups: no `latest` (or `current`) link duplicating one of them.
            assert all(v.startswith("v") and v[1:].isdigit() for v in versions), (stage, versions)
            assert versions == sorted(k for k in f[stage].keys()), stage
            current = node.attrs["current"]
            assert current == f[stage].attrs["current"] and current in versions, (stage, current)
            # A freshly run pipeline's current versions are the ones it wrote.
            assert current == max(versions, key=lambda v: int(v[1:])), stage
    ds = tree["ideal"][tree["ideal"].attrs["current"]].to_dataset()
    assert "energy_spectrum" in ds


def test_bending_energy_recomputed_with_numpy(quickstart_archive):
    ds = xr.open_dataset(quickstart_archive, group=current_group(quickstart_archive, "ideal"), engine="h5netcdf")
    kappa = ds["curvature"].values[0]            # (fibre, sample)
    ds_ = ds["sample_spacing"].values[0]
    length = ds["segment_length"].values[0]
    # e = (L/2) * sum(kappa^2) * ds   (eqs 6, A.3)
    e_numpy = 0.5 * length * np.nansum(kappa**2, axis=1) * ds_
    np.testing.assert_allclose(e_numpy, ds["bending_energy_from_curvature"].values[0], rtol=1e-9)
    # Parseval: e = (L^2/2) * sum |K_r|^2, with K_r = (1/N) DFT(kappa)   (eq 10, A.4)
    spectrum = np.fft.fft(kappa, axis=1) / kappa.shape[1]
    e_parseval = 0.5 * length**2 * np.sum(np.abs(spectrum) ** 2, axis=1)
    np.testing.assert_allclose(e_parseval, e_numpy, rtol=1e-9)
    np.testing.assert_allclose(ds["bending_energy_from_spectrum"].values[0], 2500.0, rtol=1e-9)
    ds.close()


def test_laydown_statistics_recomputed_with_numpy(quickstart_archive):
    """Radius of gyration (eq 5) of each stored laid fibre and the per-point mean over valid replicates."""
    ds = xr.open_dataset(quickstart_archive, group=current_group(quickstart_archive, "fibre"), engine="h5netcdf")
    laid = ds["laid_positions"].values[0]          # (replicate, laid_node, xyz)
    valid = ds["valid"].values[0].astype(bool)
    for r in range(laid.shape[0]):
        nodes = laid[r][~np.isnan(laid[r][:, 0])]
        s = np.sqrt(np.mean(np.sum((nodes - nodes.mean(axis=0)) ** 2, axis=1)))
        np.testing.assert_allclose(s, ds["radius_of_gyration"].values[0, r], rtol=1e-9)
    s_valid = ds["radius_of_gyration"].values[0][valid]
    np.testing.assert_allclose(ds["radius_of_gyration_mean"].values[0], s_valid.mean(), rtol=1e-12)
    np.testing.assert_allclose(ds["radius_of_gyration_std"].values[0], s_valid.std(ddof=1), rtol=1e-9)


def test_a_repacked_archive_reads_the_same_in_xarray(quickstart_archive, laydown_bin, tmp_path):
    """`laydown prune --repack` rewrites the file group by group and attaches the dimension
    scales anew: every version must open in xarray with the same dimensions and values."""
    import shutil
    import subprocess

    copy = tmp_path / "repacked.h5"
    shutil.copy(quickstart_archive, copy)
    subprocess.run([laydown_bin, "prune", str(copy), "--repack"], check=True, capture_output=True)
    with h5py.File(quickstart_archive, "r") as f:
        paths = [p for p, _ in version_groups(f)]
    with h5py.File(copy, "r") as f:
        assert [p for p, _ in version_groups(f)] == paths
    for path in paths:
        a = xr.open_dataset(quickstart_archive, group=path, engine="h5netcdf")
        b = xr.open_dataset(copy, group=path, engine="h5netcdf")
        assert dict(a.sizes) == dict(b.sizes), path
        for name in a.variables:
            assert a[name].dims == b[name].dims, (path, name)
        xr.testing.assert_identical(a, b)
        a.close()
        b.close()




@pytest.fixture(scope="session")
def flow_archive(laydown_bin, tmp_path_factory):
    """A laydown sweep of the fibre diameter carried through spectra, web and grid."""
    d = tmp_path_factory.mktemp("flow")
    (d / "p.yaml").write_text((ROOT / "tests" / "fixtures" / "parameter_flow.yaml").read_text())
    subprocess.run([laydown_bin, "run", "p.yaml"], check=True, cwd=d, capture_output=True)
    return d / "flow.h5"


def test_swept_parameters_are_coordinates_of_every_stage_downstream(flow_archive):
    """One naming rule: a coordinate is named after its parameter, typed, with `parameter`
    and `stage` attributes; xarray makes it a coordinate of the point dimension, in every
    stage below the one that swept it."""
    for stage in ["fibre", "spectra", "web", "grid"]:
        ds = xr.open_dataset(flow_archive, group=current_group(flow_archive, stage), engine="h5netcdf")
        assert "diameter" in ds.coords, (stage, list(ds.coords))
        d = ds.coords["diameter"]
        assert d.dims == ("point",) and d.dtype.kind == "f", stage
        assert d.attrs["parameter"] == "diameter" and d.attrs["stage"] == "fibre", (stage, d.attrs)
        np.testing.assert_array_equal(d.values, [3e-5, 5e-5])
        ds.close()
    grid = xr.open_dataset(flow_archive, group=current_group(flow_archive, "grid"), engine="h5netcdf")
    # CV against the laydown's diameter, no index bookkeeping.
    cv = grid["cv_mean"].swap_dims({"point": "diameter"})
    assert list(cv.coords["diameter"].values) == [3e-5, 5e-5]
    # The web's integer sweep stays an integer, renamed after its stage where the grid has
    # its own `input_point`.
    assert grid.coords["web_input_point"].dtype.kind == "i"
    attrs = grid.coords["web_input_point"].attrs
    assert (attrs["parameter"], attrs["stage"]) == ("input_point", "web"), attrs
    with h5py.File(flow_archive, "r") as f:
        for stage in f:
            g = f[stage][f[stage].attrs["current"]]
            for name, ds_ in g.items():
                if "parameter" in ds_.attrs:
                    assert "stage" in ds_.attrs, f"{stage}/{name}"
                    plain = ds_.attrs["parameter"].replace(".", "_")
                    assert name in (plain, f"sweep_{plain}", f"{ds_.attrs['stage']}_{plain}"), f"{stage}/{name}"


def test_physical_parameters_of_the_laid_fibres_reach_the_web(flow_archive):
    web = xr.open_dataset(flow_archive, group=current_group(flow_archive, "web"), engine="h5netcdf")
    np.testing.assert_array_equal(web["fibre_diameter"].values, [3e-5, 5e-5])
    np.testing.assert_array_equal(web["fibre_density"].values, [1200.0, 1200.0])
    assert all("fibre_diameter" in s for s in web["inherited_parameters"].values)


def test_per_replicate_values_are_on_point_and_replicate(quickstart_archive):
    """No flattened `run` or `web_fibre` axis: text per replicate (or fibre) has the same
    dimensions as the numbers beside it."""
    with h5py.File(quickstart_archive, "r") as f:
        paths = [p for p, _ in version_groups(f)]
    for path in paths:
        ds = xr.open_dataset(quickstart_archive, group=path, engine="h5netcdf")
        assert not {"run", "web_fibre"} & set(ds.sizes), (path, dict(ds.sizes))
        ds.close()
    fibre = xr.open_dataset(quickstart_archive, group=current_group(quickstart_archive, "fibre"), engine="h5netcdf")
    assert fibre["invalid_reason"].dims == fibre["valid"].dims == ("point", "replicate")
    assert ((fibre["invalid_reason"] == "") == fibre["valid"].astype(bool)).all()
    laid = xr.open_dataset(quickstart_archive, group=current_group(quickstart_archive, "laid"), engine="h5netcdf")
    assert laid["invalid_reason"].dims == laid["valid"].dims == ("point", "replicate", "fibre")


def test_flags_are_cf_flag_values(quickstart_archive):
    """Every flag is uint8 0/1 with flag_values and flag_meanings."""
    with h5py.File(quickstart_archive, "r") as f:
        found = 0
        for path, g in version_groups(f):
            for name, ds in g.items():
                if "flag_values" in ds.attrs:
                    found += 1
                    assert ds.dtype == np.uint8, f"{path}/{name}"
                    assert str(ds.attrs["flag_meanings"]) == "false true", f"{path}/{name}"
                    assert set(np.unique(ds[...])) <= {0, 1}, f"{path}/{name}"
                elif ds.dtype == np.uint8:
                    raise AssertionError(f"{path}/{name} is uint8 without flag attributes")
        assert found >= 3


LONG_NAME_LIMIT = 48


@pytest.mark.parametrize("archive", ["quickstart_archive", "flow_archive"])
def test_long_names_are_labels_and_descriptions_explain(archive, request):
    """A long_name is a short label (xarray puts it on plot axes); the explanation, where
    there is more to say, is the `description` attribute."""
    path = request.getfixturevalue(archive)
    too_long = []
    with h5py.File(path, "r") as f:
        for group, g in version_groups(f):
            for name, ds in g.items():
                label = str(ds.attrs["long_name"])
                if len(label) > LONG_NAME_LIMIT or ";" in label:
                    too_long.append(f"{group}/{name}: {label}")
                if "description" in ds.attrs:
                    assert len(str(ds.attrs["description"])) > 0, f"{group}/{name}"
    assert not too_long, "\n".join(too_long)
    grid = xr.open_dataset(path, group=current_group(path, "grid"), engine="h5netcdf")
    assert grid["expected_interior_density"].attrs["long_name"] == "expected interior areal density"
    assert "mass conservation" in grid["expected_interior_density"].attrs["description"]


CARTESIAN_PIPELINE = """pipeline: cartesian
archive: cartesian.h5
stages:
  - name: ideal
    kind: spectra
    params: {preset: none}
    sweep: {bending_energy: [2500.0, 25000.0, 250000.0], cutoff_number: [20, 50]}
    sweep_mode: cartesian
"""


def test_a_cartesian_sweep_unstacks_into_one_dimension_per_parameter(laydown_bin, tmp_path):
    """The swept parameters are typed coordinates along `point`, so xarray's own
    set_index/unstack turns a cartesian sweep into one dimension per parameter."""
    (tmp_path / "p.yaml").write_text(CARTESIAN_PIPELINE)
    subprocess.run([laydown_bin, "run", "p.yaml"], check=True, cwd=tmp_path, capture_output=True)
    path = tmp_path / "cartesian.h5"
    ds = xr.open_dataset(path, group=current_group(path, "ideal"), engine="h5netcdf")
    assert ds["cutoff_number"].dtype.kind == "i" and ds["bending_energy"].dtype.kind == "f"
    grid = ds.set_index(point=["bending_energy", "cutoff_number"]).unstack("point")
    e = grid["bending_energy_from_spectrum"].isel(fibre=0)
    assert e.dims == ("bending_energy", "cutoff_number")
    np.testing.assert_allclose(e.sel(bending_energy=25000.0, cutoff_number=50), 25000.0, rtol=1e-9)
