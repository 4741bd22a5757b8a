//! Failing cleanly: a full disk is one line naming the archive and the space needed,
//! with no `<archive>.partial` left behind and the archive unchanged; an archive path
//! that is a directory is bad input before anything is written.
mod common;
use common::*;
use laydown::archive::Archive;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A tmpfs of `size` mounted on `dir`, unmounted when dropped.
struct Tmpfs(PathBuf);
impl Tmpfs {
    fn mount(dir: &Path, size: &str) -> Result<Tmpfs, String> {
        if unsafe { libc::geteuid() } != 0 {
            return Err("not root".into());
        }
        std::fs::create_dir_all(dir).unwrap();
        let out = Command::new("mount").args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"]).arg(dir).output();
        match out {
            Ok(o) if o.status.success() => Ok(Tmpfs(dir.to_path_buf())),
            Ok(o) => Err(format!("mount failed: {}", String::from_utf8_lossy(&o.stderr).trim())),
            Err(e) => Err(format!("cannot run mount: {e}")),
        }
    }
}
impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_disk_is_one_line_and_leaves_no_partial() {
    let tmp = tempfile::tempdir().unwrap();
    let mnt = tmp.path().join("small_fs");
    let _fs = match Tmpfs::mount(&mnt, "3m") {
        Ok(fs) => fs,
        Err(why) => {
            // Straight to stderr, past the test harness's capture, so that it is seen.
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED: disk-full test needs a 3 MB tmpfs (mount -t tmpfs as root): {why}");
            return;
        }
    };
    // `small` fits in 3 MB; `heavy` (about 20 MB compressed) does not.
    write_pipeline(
        &mnt,
        "p.yaml",
        "pipeline: full\narchive: study.h5\nstages:\n  - {name: small, kind: spectra, params: {preset: spectrum1}}\n  - name: heavy\n    kind: spectra\n    params: {preset: spectrum3}\n    replicates: 1500\n",
    );
    let out = run_in(&mnt, &["run", "p.yaml"]);
    let (o, e) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{o}{e}");
    assert!(o.contains("small: wrote v1"), "{o}");
    let lines: Vec<&str> = e.lines().collect();
    assert_eq!(lines.len(), 1, "one line, not an HDF5 dump:\n{e}");
    let archive = mnt.canonicalize().unwrap().join("study.h5");
    assert!(lines[0].contains(&format!("archive {}: the file system is full", archive.display())), "{e}");
    assert!(lines[0].contains("MB free in") && lines[0].contains("MB free now"), "{e}");
    assert!(!mnt.join("study.h5.partial").exists(), ".partial left behind");
    let a = Archive::open_read(&archive).unwrap();
    assert_eq!(a.versions("small").unwrap().len(), 1);
    assert!(a.versions("heavy").unwrap().is_empty());
}

#[test]
fn a_directory_as_archive_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::create_dir(tmp.path().join("results")).unwrap();
    write_pipeline(tmp.path(), "p.yaml", "pipeline: d\narchive: results\nstages:\n  - {name: s, kind: spectra}\n");
    for args in [&["validate", "p.yaml"][..], &["run", "p.yaml"]] {
        let out = run_in(tmp.path(), args);
        let (o, e) = text(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {e}");
        assert!(o.is_empty(), "{o}");
        assert!(e.contains("p.yaml:2:10: archive: `results` is a directory"), "{e}");
    }
    // Given on the command line instead.
    write_pipeline(tmp.path(), "q.yaml", "pipeline: d\narchive: study.h5\nstages:\n  - {name: s, kind: spectra}\n");
    let out = run_in(tmp.path(), &["run", "q.yaml", "--archive", "results"]);
    let (_, e) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{e}");
    assert!(e.contains("--archive: `results` is a directory"), "{e}");
    assert_eq!(std::fs::read_dir(tmp.path().join("results")).unwrap().count(), 0, "nothing may be written into it");
    assert!(!tmp.path().join("study.h5").exists());
}
