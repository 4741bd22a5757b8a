//! The study archive: one self-contained HDF5 file per study whose groups
//! `/<stage>/v<N>` hold every run of every stage with its provenance, the attribute
//! `current` on each `/<stage>` naming the version the pipeline's last run matched or
//! wrote ([`Archive::current`]), and root attributes (`Conventions`, `history`,
//! `layout_version`).
//!
//! # Crash safety
//! HDF5 1.10 has no journaling and a process killed mid-write can corrupt the file it
//! was writing, so the archive is never modified in place. A stage's results are
//! computed in memory; committing them copies the archive to `<archive>.partial`
//! (a reflink where the file system supports it), appends the new version group there,
//! flushes and fsyncs it, and renames it over the archive (atomic on POSIX). A process
//! killed at any moment leaves either the old or the new archive, both complete; a
//! version group exists only once complete (`status = complete`). A failed commit, or
//! SIGINT/SIGTERM/SIGHUP during one, removes `.partial`; one left by SIGKILL is removed
//! by the next run. `<archive>.lock` (an OS file lock, released by the
//! kernel when the process dies) makes a second concurrent `laydown run` fail fast. All
//! of this happens beside the real file ([`resolve`]), whatever path named it.
//!
//! The cost is one copy of the archive per committed stage version; see README.
//! `schemas/archive_layout.md` documents the groups, datasets and attributes.
//!
//! # Integrity
//! Each version stores the hash of every dataset (`dataset_hashes`, see
//! [`hdf::dataset_hashes`]) and `content_hash`, the hash of those. [`VersionInfo::verify`]
//! reads every value back and names each dataset that no longer matches.
pub mod data;
pub mod export;
pub mod gather;
pub mod hdf;
pub mod provenance;
pub mod prune;

use crate::error::BadInput;
use anyhow::{anyhow, bail, Context, Result};
use data::{Attr, Output};
use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

/// Version of the archive layout described in schemas/archive_layout.md.
/// 2: `/<stage>` carries `current`; the `latest` soft links of layout 1 are gone.
pub const LAYOUT_VERSION: i64 = 2;

/// The attribute of `/<stage>` naming its current version (`v3`).
pub const CURRENT_ATTR: &str = "current";

/// The attribute of `/<stage>` holding the highest version number ever written, set by
/// `laydown prune` when it removes versions (see [`Archive::next_version`]).
pub const HIGHEST_ATTR: &str = "highest_version";

/// Parse a stage reference `STAGE` or `STAGE@vN` (the version number, when given).
pub fn parse_stage_ref(s: &str) -> Result<(String, Option<u32>)> {
    match s.split_once('@') {
        None => Ok((s.to_string(), None)),
        Some((name, v)) => {
            let n = v
                .strip_prefix('v')
                .and_then(|n| n.parse().ok())
                .ok_or_else(|| BadInput(format!("`{s}`: expected STAGE or STAGE@vN, e.g. fibre@v2")))?;
            Ok((name.to_string(), Some(n)))
        }
    }
}

/// Where the figures of `stage` version `number` go: `<archive stem>_figures/<stage>/v<number>/`
/// beside the archive (used by stages that draw while they run and by `laydown plot`).
pub fn figure_dir(archive: &Path, stage: &str, number: u32) -> PathBuf {
    let stem = archive.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "archive".into());
    archive.with_file_name(format!("{stem}_figures")).join(stage).join(format!("v{number}"))
}

/// One complete version of a stage, as found in the archive.
#[derive(Debug, Clone)]
pub struct VersionInfo {
    pub stage: String,
    pub number: u32,
    /// The archive file holding it.
    pub file: PathBuf,
    pub attrs: BTreeMap<String, Attr>,
}

impl VersionInfo {
    /// Group path inside the archive.
    pub fn group_path(&self) -> String {
        format!("/{}/v{}", self.stage, self.number)
    }
    pub fn attr_str(&self, key: &str) -> Option<&str> {
        match self.attrs.get(key) {
            Some(Attr::Str(s)) => Some(s),
            _ => None,
        }
    }
    pub fn attr_f64(&self, key: &str) -> Option<f64> {
        match self.attrs.get(key) {
            Some(Attr::F64(v)) => Some(*v),
            Some(Attr::I64(v)) => Some(*v as f64),
            _ => None,
        }
    }
    pub fn is_complete(&self) -> bool {
        self.attr_str("status") == Some("complete")
    }
    /// Check every dataset of the version against the hashes stored when it was
    /// committed (`dataset_hashes`, whose hash is `content_hash`), reading every value.
    pub fn verify(&self) -> Integrity {
        let Some(stored) = self.attr_str("dataset_hashes") else { return Integrity::Unverifiable };
        let expected = hdf::parse_dataset_hashes(stored);
        let mut problems = vec![];
        if self.attr_str("content_hash") != Some(hdf::hash_of_dataset_hashes(&expected).as_str()) {
            problems.push("attribute `dataset_hashes` does not match `content_hash`".to_string());
        }
        let group = match self.open() {
            Ok(g) => g,
            Err(e) => return Integrity::Damaged(vec![format!("the group cannot be opened ({})", first_line(&e))]),
        };
        for (name, hash) in &expected {
            match group.dataset(name) {
                Err(_) => problems.push(format!("dataset `{name}` is missing")),
                Ok(ds) => match hdf::read_dataset_hash(&ds) {
                    Err(e) => problems.push(format!("dataset `{name}` cannot be read ({})", first_line(&e))),
                    Ok(h) if &h != hash => problems.push(format!("dataset `{name}` differs from its stored hash")),
                    Ok(_) => {}
                },
            }
        }
        for name in group.member_names().unwrap_or_default() {
            if !expected.contains_key(&name) && group.dataset(&name).is_ok() {
                problems.push(format!("dataset `{name}` was not there when the version was committed"));
            }
        }
        if problems.is_empty() {
            Integrity::Ok
        } else {
            Integrity::Damaged(problems)
        }
    }

    /// One line for a damaged version: the file, the group, what is wrong and what to do.
    pub fn damage_message(&self, problems: &[String]) -> String {
        let pipeline = self.attr_str("pipeline_file").unwrap_or("PIPELINE");
        format!(
            "archive {}: {} is damaged: {}; do not use it: `laydown run {pipeline} --force {}` computes it again (`laydown verify {}` lists all damage)",
            self.file.display(),
            self.group_path(),
            problems.join("; "),
            self.stage,
            self.file.display()
        )
    }

    /// [`Self::verify`] as a result: damage is an error carrying [`Self::damage_message`].
    pub fn check(&self) -> Result<()> {
        match self.verify() {
            Integrity::Damaged(problems) => bail!(self.damage_message(&problems)),
            Integrity::Ok | Integrity::Unverifiable => Ok(()),
        }
    }

    /// Open the version's group for reading.
    pub fn open(&self) -> Result<hdf5::Group> {
        let file = open_hdf5(&self.file)?;
        file.group(&self.group_path())
            .with_context(|| format!("{} has no group {}", self.file.display(), self.group_path()))
    }
}

/// What [`VersionInfo::verify`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Integrity {
    Ok,
    /// Written before versions stored per-dataset hashes: nothing to check against.
    Unverifiable,
    /// One entry per problem: `dataset `x` differs from its stored hash`, ...
    Damaged(Vec<String>),
}

fn first_line(e: &anyhow::Error) -> String {
    e.to_string().lines().next().unwrap_or("").trim().to_string()
}

/// An archive on disk (which may not exist yet).
pub struct Archive {
    pub path: PathBuf,
    _lock: Option<fs::File>,
}

impl Archive {
    /// Open for reading; nothing is created.
    pub fn open_read(path: &Path) -> Result<Self> {
        if !path.exists() {
            return Err(BadInput(format!("archive {} does not exist; give the path of an archive written by `laydown run`", path.display())).into());
        }
        if path.is_dir() {
            return Err(BadInput(format!("archive {} is a directory; give the path of an HDF5 file", path.display())).into());
        }
        Ok(Archive { path: path.to_path_buf(), _lock: None })
    }

    /// Open for reading what is there, if anything (a dry run): a missing archive reads
    /// as empty; nothing is created, locked or removed.
    pub fn open_if_exists(path: &Path) -> Result<Self> {
        if path.is_dir() {
            bail!("archive {} is a directory; give the path of an HDF5 file, e.g. {}", path.display(), path.join("study.h5").display());
        }
        let path = resolve(path).unwrap_or_else(|_| resolve_existing_part(path));
        Ok(Archive { path, _lock: None })
    }

    /// Open for writing: takes the run lock (failing fast if another run holds it) and
    /// removes a temporary copy left by a killed run. Creates nothing else.
    ///
    /// The path is resolved first ([`resolve`]): the lock, the temporary copy and the
    /// commit's rename all work on the real file, so runs through a symlink and through
    /// the file itself share one lock and one archive, and the symlink stays a symlink.
    pub fn open_write(path: &Path) -> Result<Self> {
        if let Some(parent) = path.parent() {
            if !parent.as_os_str().is_empty() {
                fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
            }
        }
        let path = &resolve(path)?;
        if path.is_dir() {
            bail!("archive {} is a directory; give the path of an HDF5 file, e.g. {}", path.display(), path.join("study.h5").display());
        }
        let lock_path = sibling(path, ".lock");
        let lock = fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .with_context(|| format!("opening {}", lock_path.display()))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(fs::TryLockError::WouldBlock) => bail!(
                "archive {} is in use by another `laydown run` (lock {} is held); wait for it to finish",
                path.display(),
                lock_path.display()
            ),
            Err(fs::TryLockError::Error(e)) => return Err(e).context("locking the archive"),
        }
        let partial = sibling(path, ".partial");
        if partial.exists() {
            fs::remove_file(&partial).with_context(|| format!("removing stale {}", partial.display()))?;
        }
        Ok(Archive { path: path.to_path_buf(), _lock: Some(lock) })
    }

    /// Stage names that have versions, sorted.
    pub fn stages(&self) -> Result<Vec<String>> {
        if !self.path.exists() {
            return Ok(vec![]);
        }
        let file = open_hdf5(&self.path)?;
        let mut out: Vec<String> = file.groups()?.iter().map(|g| g.name().trim_start_matches('/').to_string()).collect();
        out.sort();
        Ok(out)
    }

    /// All versions of a stage, oldest first.
    pub fn versions(&self, stage: &str) -> Result<Vec<VersionInfo>> {
        if !self.path.exists() {
            return Ok(vec![]);
        }
        let file = open_hdf5(&self.path)?;
        let Ok(group) = file.group(stage) else { return Ok(vec![]) };
        let mut out = vec![];
        for name in group.member_names()? {
            let Some(number) = name.strip_prefix('v').and_then(|n| n.parse::<u32>().ok()) else { continue };
            let vgroup = group.group(&name)?;
            let attrs = hdf::read_attrs(&vgroup)?;
            out.push(VersionInfo { stage: stage.to_string(), number, file: self.path.clone(), attrs });
        }
        out.sort_by_key(|v| v.number);
        Ok(out)
    }

    /// Version `number` of a stage, or with `None` its current one ([`Self::current`]).
    pub fn version(&self, stage: &str, number: Option<u32>) -> Result<VersionInfo> {
        let versions = self.versions(stage)?;
        if versions.is_empty() {
            let stages = self.stages()?;
            return Err(BadInput(format!("stage `{stage}` has no versions in {}; stages present: {}", self.path.display(), stages.join(", "))).into());
        }
        let number = match number {
            Some(n) => Some(n),
            None => self.current(stage)?,
        };
        let found = match number {
            Some(n) => versions.iter().find(|v| v.number == n).cloned(),
            None => versions.last().cloned(),
        };
        found.ok_or_else(|| {
            let have: Vec<String> = versions.iter().map(|v| format!("v{}", v.number)).collect();
            BadInput(format!("stage `{stage}` has no version v{} in {}; it has {}", number.unwrap_or(0), self.path.display(), have.join(", "))).into()
        })
    }

    /// The current version of a stage: the one the pipeline's last run matched or wrote
    /// (attribute `current` of `/<stage>`). `None` when the stage has no versions or none
    /// is marked (archives of layout 1, before marks existed).
    pub fn current(&self, stage: &str) -> Result<Option<u32>> {
        Ok(self.current_marks()?.get(stage).copied())
    }

    /// Every stage's current version ([`Self::current`]), by stage name.
    pub fn current_marks(&self) -> Result<BTreeMap<String, u32>> {
        let mut marks = BTreeMap::new();
        if !self.path.exists() {
            return Ok(marks);
        }
        let file = open_hdf5(&self.path)?;
        for group in file.groups()? {
            let stage = group.name().trim_start_matches('/').to_string();
            let Some(Attr::Str(mark)) = hdf::read_attrs(&group)?.remove(CURRENT_ATTR) else { continue };
            // A mark naming no complete group (never written so) is ignored, not trusted.
            let number = mark.strip_prefix('v').and_then(|n| n.parse::<u32>().ok());
            if let Some(n) = number.filter(|n| group.link_exists(&format!("v{n}"))) {
                marks.insert(stage, n);
            }
        }
        Ok(marks)
    }

    /// Commit a new version of `stage` (and a `history` line), marked current; returns
    /// its number. Atomic: see the module docs.
    pub fn commit_version(
        &self,
        title: &str,
        stage: &str,
        out: &Output,
        attrs: &BTreeMap<String, Attr>,
        history_line: &str,
    ) -> Result<u32> {
        self.commit_version_marking(title, stage, out, attrs, &BTreeMap::new(), history_line)
    }

    /// [`Self::commit_version`], also marking the versions in `marks` (stage -> number)
    /// current in the same atomic commit.
    pub fn commit_version_marking(
        &self,
        title: &str,
        stage: &str,
        out: &Output,
        attrs: &BTreeMap<String, Attr>,
        marks: &BTreeMap<String, u32>,
        history_line: &str,
    ) -> Result<u32> {
        let number = self.next_version(stage)?;
        let mut marks = marks.clone();
        marks.insert(stage.to_string(), number);
        self.transaction(title, history_line, out.byte_size(), |file| {
            let sgroup = match file.group(stage) {
                Ok(g) => g,
                Err(_) => file.create_group(stage)?,
            };
            let group = sgroup.create_group(&format!("v{number}"))?;
            hdf::write_output(&group, out)?;
            let mut all = attrs.clone();
            all.insert("version".into(), Attr::I64(number as i64));
            for (k, a) in &all {
                hdf::write_attr(&group, k, a)?;
            }
            write_marks(file, &marks)
        })?;
        Ok(number)
    }

    /// The number the next version of `stage` gets: one past the highest ever written,
    /// also when `laydown prune` removed it (attribute [`HIGHEST_ATTR`] of `/<stage>`), so
    /// that a number never names two different results (figures, notes, other archives).
    pub fn next_version(&self, stage: &str) -> Result<u32> {
        let newest = self.versions(stage)?.last().map_or(0, |v| v.number);
        let mut pruned = 0;
        if self.path.exists() {
            if let Ok(group) = open_hdf5(&self.path)?.group(stage) {
                if let Some(Attr::I64(n)) = hdf::read_attrs(&group)?.remove(HIGHEST_ATTR) {
                    pruned = n.max(0) as u32;
                }
            }
        }
        Ok(newest.max(pruned) + 1)
    }

    /// Mark versions current (stage -> number) without adding any, in one atomic commit
    /// with a `history` line. Every stage named must have that version.
    pub fn mark_current(&self, title: &str, marks: &BTreeMap<String, u32>, history_line: &str) -> Result<()> {
        for (stage, &n) in marks {
            if !self.versions(stage)?.iter().any(|v| v.number == n) {
                bail!("archive {}: cannot mark /{stage}/v{n} current: there is no such version", self.path.display());
            }
        }
        self.transaction(title, history_line, 0, |file| write_marks(file, marks))
    }

    /// Copy the archive (or start a new one), apply `f`, update the root attributes,
    /// sync and rename into place. On any failure `<archive>.partial` is removed and the
    /// archive is untouched; a full file system is reported in one line with the space
    /// needed (`new_bytes`: the uncompressed size of what `f` adds).
    fn transaction(&self, title: &str, history_line: &str, new_bytes: u64, f: impl FnOnce(&hdf5::File) -> Result<()>) -> Result<()> {
        let partial = sibling(&self.path, ".partial");
        let guard = PartialGuard::install(&partial);
        let result = write_partial(&self.path, &partial, title, history_line, f).and_then(|()| {
            fs::rename(&partial, &self.path).with_context(|| format!("renaming {} to {}", partial.display(), self.path.display()))
        });
        drop(guard);
        if let Err(e) = result {
            // The HDF5 handle is closed (dropped in write_partial), so the copy can go.
            let _ = fs::remove_file(&partial);
            return Err(self.explain_failure(e, new_bytes));
        }
        // Persist the rename itself (the directory entry).
        if let Ok(d) = fs::File::open(self.dir()) {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// The directory holding the archive.
    fn dir(&self) -> &Path {
        match self.path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        }
    }

    /// A failed commit as one line: a full file system (ENOSPC, which HDF5 reports as
    /// `errno = 28` in its message) names the archive and the space needed (a copy of the
    /// archive plus the new version); anything else keeps the first line of its cause.
    fn explain_failure(&self, e: anyhow::Error, new_bytes: u64) -> anyhow::Error {
        let old = fs::metadata(&self.path).map(|m| m.len()).unwrap_or(0);
        // The copy, the new data (uncompressed, an upper bound) and HDF5's metadata.
        let needed = old + new_bytes + (1 << 20);
        let free = free_bytes(self.dir());
        let no_space = e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>().is_some_and(|io| io.raw_os_error() == Some(libc::ENOSPC))
                || c.to_string().contains("No space left on device")
                || c.to_string().contains("errno = 28")
        });
        if no_space {
            let mb = |b: u64| b as f64 / 1e6;
            return anyhow!(
                "archive {}: the file system is full: committing needs up to {:.1} MB free in {} ({:.1} MB free now); free some space or move the archive, then rerun (the archive is unchanged)",
                self.path.display(),
                mb(needed),
                self.dir().display(),
                mb(free.unwrap_or(0)),
            );
        }
        let first = e.to_string();
        let first = first.lines().next().unwrap_or("").trim().to_string();
        anyhow!("archive {}: committing failed, the archive is unchanged: {first}", self.path.display())
    }
}

/// Write the `current` marks into an archive being committed, and drop the `latest` soft
/// links of layout 1 (they named the newest version, not the current one, and appear as
/// duplicate groups in `xarray.open_datatree`).
fn write_marks(file: &hdf5::File, marks: &BTreeMap<String, u32>) -> Result<()> {
    for (stage, n) in marks {
        let group = file.group(stage).with_context(|| format!("marking /{stage}/v{n} current"))?;
        if group.attr(CURRENT_ATTR).is_ok() {
            group.delete_attr(CURRENT_ATTR)?;
        }
        hdf::write_attr(&group, CURRENT_ATTR, &Attr::Str(format!("v{n}")))?;
    }
    for group in file.groups()? {
        if group.link_exists("latest") {
            group.unlink("latest")?;
        }
    }
    Ok(())
}

/// The `.partial` file a commit is writing, for [`remove_partial_and_die`]; null when none.
static PARTIAL_PATH: std::sync::atomic::AtomicPtr<libc::c_char> = std::sync::atomic::AtomicPtr::new(std::ptr::null_mut());

/// Signals that end a run (Ctrl-C, `kill`, a closed terminal).
const FATAL_SIGNALS: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

extern "C" fn remove_partial_and_die(sig: libc::c_int) {
    // Only async-signal-safe calls: unlink, signal, raise.
    let path = PARTIAL_PATH.load(std::sync::atomic::Ordering::SeqCst);
    unsafe {
        if !path.is_null() {
            libc::unlink(path);
        }
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
}

/// While a commit writes `<archive>.partial`, SIGINT, SIGTERM and SIGHUP remove it
/// before the process dies of the signal (SIGKILL cannot be caught: the next run removes
/// the file). Dropping the guard restores the previous handlers.
struct PartialGuard {
    handlers: Option<crate::signal_scope::Handlers>,
}

impl PartialGuard {
    fn install(partial: &Path) -> Self {
        use std::os::unix::ffi::OsStrExt;
        // Leaked on purpose (one short path per commit): a handler running on another
        // thread may still read it after the guard is dropped.
        if let Ok(c) = std::ffi::CString::new(partial.as_os_str().as_bytes()) {
            PARTIAL_PATH.store(c.into_raw(), std::sync::atomic::Ordering::SeqCst);
        }
        PartialGuard { handlers: Some(crate::signal_scope::Handlers::install(&FATAL_SIGNALS, remove_partial_and_die, 0)) }
    }
}

impl Drop for PartialGuard {
    fn drop(&mut self) {
        // the previous handlers first, then the path they read
        drop(self.handlers.take());
        PARTIAL_PATH.store(std::ptr::null_mut(), std::sync::atomic::Ordering::SeqCst);
    }
}

/// Write the archive's next state into `partial` (a copy of `path`, or a new file) and fsync it.
fn write_partial(path: &Path, partial: &Path, title: &str, history_line: &str, f: impl FnOnce(&hdf5::File) -> Result<()>) -> Result<()> {
    let file = if path.exists() {
        fs::copy(path, partial).with_context(|| format!("copying {} to {}", path.display(), partial.display()))?;
        hdf5::File::open_rw(partial)?
    } else {
        hdf5::File::create(partial).with_context(|| format!("creating {}", partial.display()))?
    };
    let mut history = match hdf::read_attrs(&file)?.get("history") {
        Some(Attr::Str(h)) => h.clone(),
        _ => String::new(),
    };
    f(&file)?;
    if !history.is_empty() && !history.ends_with('\n') {
        history.push('\n');
    }
    history.push_str(history_line);
    let root: [(&str, Attr); 5] = [
        ("Conventions", Attr::Str("CF-1.8".into())),
        ("title", Attr::Str(title.into())),
        ("source", Attr::Str(format!("laydown {}", env!("CARGO_PKG_VERSION")))),
        ("history", Attr::Str(history)),
        ("layout_version", Attr::I64(LAYOUT_VERSION)),
    ];
    for (k, v) in &root {
        if file.attr(k).is_ok() {
            file.delete_attr(k)?;
        }
        hdf::write_attr(&file, k, v)?;
    }
    file.flush()?;
    file.close()?;
    fs::File::open(partial)?.sync_all()?;
    Ok(())
}

/// Free bytes for an unprivileged user on the file system holding `dir`.
fn free_bytes(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    (unsafe { libc::statvfs(c.as_ptr(), &mut st) } == 0).then(|| st.f_bavail as u64 * st.f_frsize as u64)
}

/// Open an archive file for reading; a file HDF5 cannot open is reported as damaged, in one line.
pub fn open_hdf5(path: &Path) -> Result<hdf5::File> {
    hdf5::File::open(path).map_err(|e| {
        let why = e.to_string();
        let why = why.lines().next().unwrap_or("").trim().trim_start_matches("H5Fopen(): ");
        anyhow!(
            "archive {} cannot be opened by HDF5 ({why}): it is damaged or not a laydown archive; restore it from a copy, or run the pipeline again into a new archive (`laydown run P --archive NEW.h5`)",
            path.display()
        )
    })
}

/// The real path of an archive: symlinks (also a chain of them, or one to a file that
/// does not exist yet) and `.`/`..` resolved, absolute. The archive's directory must exist.
pub fn resolve(path: &Path) -> Result<PathBuf> {
    let mut path = path.to_path_buf();
    for _ in 0..40 {
        match fs::symlink_metadata(&path) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = fs::read_link(&path).with_context(|| format!("reading the symlink {}", path.display()))?;
                path = match path.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            Ok(_) => return fs::canonicalize(&path).with_context(|| format!("resolving {}", path.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                // Not there yet: resolve its directory; the file name is kept.
                let name = path.file_name().ok_or_else(|| anyhow!("archive path {} does not name a file", path.display()))?;
                let dir = match path.parent() {
                    Some(d) if !d.as_os_str().is_empty() => d,
                    _ => Path::new("."),
                };
                let dir = fs::canonicalize(dir).with_context(|| format!("the archive's directory {} does not exist", dir.display()))?;
                return Ok(dir.join(name));
            }
            Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
        }
    }
    bail!("archive path {} is a loop of symlinks; make it point to an HDF5 file", path.display())
}

/// A path whose directory may not exist yet, for display: its longest existing ancestor
/// resolved ([`fs::canonicalize`]), the rest appended (`..` there taken lexically: nothing
/// in it exists, so no symlink can be involved).
fn resolve_existing_part(path: &Path) -> PathBuf {
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut base = absolute.as_path();
    let mut rest = vec![];
    while !base.exists() {
        match (base.parent(), base.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                base = parent;
            }
            _ => return absolute,
        }
    }
    let mut out = fs::canonicalize(base).unwrap_or_else(|_| base.to_path_buf());
    for part in rest.iter().rev() {
        out.push(part);
    }
    out
}

/// An archive path as the pipeline names it, made absolute: its directory resolved
/// (symlinks, `.` and `..`; a part that does not exist yet taken lexically) and its file
/// name kept, so a symlinked archive stays the symlink (figures go beside it, as
/// `laydown plot` puts them). Used for `archive:` and `--archive`.
pub fn absolute(path: &Path) -> PathBuf {
    match (path.parent(), path.file_name()) {
        (Some(dir), Some(name)) => {
            let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
            resolve_existing_part(dir).join(name)
        }
        _ => std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf()),
    }
}

/// `<archive><suffix>` beside the archive.
fn sibling(path: &Path, suffix: &str) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(suffix);
    path.with_file_name(name)
}
