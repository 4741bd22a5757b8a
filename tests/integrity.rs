//! Integrity: every version stores a hash per dataset (and `content_hash` over them);
//! `laydown verify` checks every version and names each damaged group and dataset;
//! `show` and `plot` refuse a damaged version; `run` recomputes a damaged up-to-date
//! stage and says so, and refuses to read a damaged input. The damage is done the hard
//! way: random bytes written over a dataset's data in the middle of the archive file.
mod common;
use common::*;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

const PIPE: &str = "pipeline: integrity
archive: study.h5
seed: 7
stages:
  - name: ideal
    kind: spectra
    params: {preset: spectrum1}
    replicates: 2
  - name: web
    kind: web
    input: ideal
    params: {fibres_across: 400, fibre_spacing: 0.0005, segments_per_fibre: 40, belt_speed_ratio: 0.04}
  - name: grid
    kind: grid
    input: web
    params: {cell_size: 0.001, window_side: 0.1, boundary: periodic}
";

/// Where a dataset's bytes are in the file: (offset, length) of its contiguous data or
/// of its first chunk.
fn data_location(archive: &Path, group: &str, dataset: &str) -> (u64, u64) {
    let file = hdf5::File::open(archive).unwrap();
    let ds = file.group(group).unwrap().dataset(dataset).unwrap();
    match ds.offset() {
        Some(o) => (o, ds.storage_size()),
        None => {
            let c = ds.chunk_info(0).expect("chunked dataset");
            (c.addr, c.size)
        }
    }
}

/// Every contiguous dataset of the archive with at least 64 bytes: (group, name, offset).
fn contiguous_datasets(archive: &Path) -> Vec<(String, String, u64)> {
    let file = hdf5::File::open(archive).unwrap();
    let mut out = vec![];
    for stage in file.member_names().unwrap() {
        let group = format!("/{stage}/v1");
        let g = file.group(&group).unwrap();
        for name in g.member_names().unwrap() {
            if let Ok(ds) = g.dataset(&name) {
                if let (Some(o), true) = (ds.offset(), ds.storage_size() >= 64) {
                    out.push((group.clone(), name, o));
                }
            }
        }
    }
    out
}

/// Overwrite `len` bytes at `offset` with pseudo-random bytes that differ from the old ones.
fn scribble(archive: &Path, offset: u64, len: u64) {
    let mut bytes = std::fs::read(archive).unwrap()[offset as usize..(offset + len) as usize].to_vec();
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    for b in bytes.iter_mut() {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        *b ^= (x as u8) | 1; // never the same byte again
    }
    let mut f = std::fs::OpenOptions::new().write(true).open(archive).unwrap();
    f.seek(SeekFrom::Start(offset)).unwrap();
    f.write_all(&bytes).unwrap();
}

fn setup() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    write_pipeline(tmp.path(), "p.yaml", PIPE);
    let out = run_in(tmp.path(), &["run", "p.yaml"]);
    assert_eq!(out.status.code(), Some(0), "{:?}", text(&out));
    let out = run_in(tmp.path(), &["verify", "study.h5"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{o}{e}");
    assert_eq!(o.lines().filter(|l| l.starts_with("ok ")).count(), 3, "{o}");
    tmp
}

#[test]
fn random_bytes_in_the_middle_are_found_named_and_recomputed() {
    let tmp = setup();
    let d = tmp.path();
    let archive = d.join("study.h5");
    // The contiguous dataset whose data lies nearest the middle of the file.
    let middle = std::fs::metadata(&archive).unwrap().len() / 2;
    let (group, name, offset) =
        contiguous_datasets(&archive).into_iter().min_by_key(|(_, _, o)| o.abs_diff(middle)).expect("a contiguous dataset");
    let stage = group.trim_start_matches('/').split('/').next().unwrap().to_string();
    scribble(&archive, offset, 64);

    // verify: exit 1, the damaged group and dataset named, the others ok.
    let out = run_in(d, &["verify", "study.h5"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{o}{e}");
    assert!(o.contains(&format!("DAMAGED    {group}: dataset `{name}` differs from its stored hash")), "{o}");
    assert_eq!(o.lines().filter(|l| l.starts_with("ok ")).count(), 2, "{o}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains(&format!("archive study.h5: 1 of 3 versions damaged ({group})")) && e.contains(&format!("--force {stage}")), "{e}");

    // show and plot refuse it (exit 1, nothing on stdout), naming file, group and dataset.
    for args in [&["show", "study.h5", stage.as_str()][..], &["plot", "study.h5", stage.as_str()]] {
        let out = run_in(d, args);
        let (o, e) = text(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {e}");
        assert!(o.is_empty(), "{o}");
        assert!(e.contains(&format!("archive study.h5: {group} is damaged: dataset `{name}`")), "{e}");
    }

    // run: the damaged up-to-date stage is computed again, and says so.
    let out = run_in(d, &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{o}{e}");
    assert!(o.contains(&format!("{stage}: runs: stored v1 is damaged (dataset `{name}` differs from its stored hash); computing it again")), "{o}");
    assert!(e.contains(&format!("{group} is damaged")), "{e}");
    // Same results as before the damage, so what reads it is still up to date.
    for s in ["ideal", "web", "grid"].into_iter().filter(|s| *s != stage) {
        assert!(o.contains(&format!("{s}: up to date (v1)")), "{o}");
    }
    let out = run_in(d, &["run", "p.yaml"]);
    assert!(text(&out).0.contains(&format!("{stage}: up to date (v2)")), "{:?}", text(&out));
}

#[test]
fn a_damaged_compressed_input_is_never_read() {
    let tmp = setup();
    let d = tmp.path();
    let archive = d.join("study.h5");
    // The web's fibre coordinates are large: chunked and compressed.
    let file = hdf5::File::open(&archive).unwrap();
    let web = file.group("/web/v1").unwrap();
    let chunked = web
        .member_names()
        .unwrap()
        .into_iter()
        .find(|n| web.dataset(n).is_ok_and(|ds| ds.offset().is_none() && ds.is_chunked()))
        .expect("a chunked dataset in /web/v1");
    drop(web);
    drop(file);
    let (offset, len) = data_location(&archive, "/web/v1", &chunked);
    scribble(&archive, offset + len / 4, (len / 2).min(4096));

    let out = run_in(d, &["verify", "study.h5"]);
    let (o, _) = text(&out);
    assert_eq!(out.status.code(), Some(1));
    assert!(o.contains(&format!("DAMAGED    /web/v1: dataset `{chunked}`")), "{o}");

    // The grid reads the web: with --only the web is not recomputed, so the grid refuses it.
    let out = run_in(d, &["run", "p.yaml", "--only", "grid", "--force", "grid"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.contains("stage `grid` needs input /web/v1: archive ") && e.contains(&format!("/web/v1 is damaged: dataset `{chunked}`")), "{e}");
    assert!(e.contains("--force web"), "{e}");
}

#[test]
fn an_input_without_dataset_hashes_is_used_with_a_note() {
    let tmp = setup();
    let d = tmp.path();
    {
        let f = hdf5::File::open_rw(d.join("study.h5")).unwrap();
        f.group("/web/v1").unwrap().delete_attr("dataset_hashes").unwrap();
    }
    // A child spawned by another test thread while the file was open here may hold its lock.
    fresh_inode(&d.join("study.h5"));
    let out = run_in(d, &["verify", "study.h5"]);
    let (o, _) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{o}");
    assert!(o.contains("unchecked  /web/v1 (written before laydown stored dataset hashes)"), "{o}");
    let out = run_in(d, &["run", "p.yaml", "--only", "grid", "--force", "grid"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(0), "{o}{e}");
    assert!(e.contains("note: archive ") && e.contains("input /web/v1 was written before laydown stored dataset hashes and cannot be verified; `laydown run p.yaml --force web` rewrites it"), "{e}");
}
