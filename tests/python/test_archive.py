"""The archive as researchers read it: h5py, xarray (h5netcdf), numpy recomputation."""
import h5py
import numpy as np
import xarray as xr

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
