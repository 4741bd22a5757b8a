//! `laydown prune`: remove the versions a study no longer uses, crash-safely.
//!
//! Kept, per stage: the current version, the `keep` newest other complete versions, and
//! every version that a kept version names as its input (`inputs` provenance), followed
//! upstream to the end, so that no kept version loses the data it was computed from. A
//! stage with no `current` mark (an archive written before marks existed) is kept whole.
//! Everything else is removed in one commit through the archive's own transaction (copy
//! to `<archive>.partial`, unlink, fsync, rename): a prune killed at any moment leaves the
//! archive as it was or pruned, never half pruned. The run lock is held throughout. The
//! figure folders of removed versions (`<archive stem>_figures/<stage>/v<N>`) are
//! deleted after the commit.
//!
//! HDF5 does not give back the space of unlinked groups: the file keeps its size (later
//! commits copy it whole). [`repack`] writes the kept groups into a new file, group by
//! group (`H5Ocopy`, then each version's dimension scales attached anew, since a copy
//! leaves their object references pointing into the old file), and renames it
//! over the archive, again atomically.
use super::data::Attr;
use super::{hdf, sibling, Archive, PartialGuard, VersionInfo};
use anyhow::{anyhow, bail, Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::fs;

/// What a prune keeps and removes.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    /// `(stage, version, why kept)`, stages by name, versions ascending.
    pub kept: Vec<(String, u32, String)>,
    /// `(stage, version)` removed.
    pub removed: Vec<(String, u32)>,
}

impl Plan {
    pub fn is_empty(&self) -> bool {
        self.removed.is_empty()
    }
}

/// `/fibre/v1 content_hash=...` lines of a version's `inputs` attribute, as (stage, version).
fn inputs_of(v: &VersionInfo) -> Vec<(String, u32)> {
    v.attr_str("inputs")
        .unwrap_or("")
        .lines()
        .filter_map(|l| {
            let group = l.split_whitespace().next()?;
            let (stage, n) = group.trim_start_matches('/').rsplit_once("/v")?;
            Some((stage.to_string(), n.parse().ok()?))
        })
        .collect()
}

/// Decide what a prune keeping `keep` non-current versions per stage would remove.
pub fn plan(archive: &Archive, keep: usize) -> Result<Plan> {
    let marks = archive.current_marks()?;
    let mut all: BTreeMap<String, Vec<VersionInfo>> = BTreeMap::new();
    for stage in archive.stages()? {
        all.insert(stage.clone(), archive.versions(&stage)?);
    }
    // Why each kept version is kept (the first reason found).
    let mut kept: BTreeMap<(String, u32), String> = BTreeMap::new();
    for (stage, versions) in &all {
        match marks.get(stage) {
            None => {
                for v in versions {
                    kept.insert((stage.clone(), v.number), "no version is marked current (an older archive): stage kept whole".into());
                }
            }
            Some(&current) => {
                kept.insert((stage.clone(), current), "current".into());
                let others = versions.iter().rev().filter(|v| v.number != current && v.is_complete());
                for v in others.take(keep) {
                    kept.insert((stage.clone(), v.number), format!("one of the {keep} newest non-current (--keep)"));
                }
            }
        }
    }
    // Follow inputs upstream from every kept version until nothing new is added.
    let mut todo: Vec<(String, u32)> = kept.keys().cloned().collect();
    while let Some((stage, n)) = todo.pop() {
        let Some(v) = all.get(&stage).and_then(|vs| vs.iter().find(|v| v.number == n)) else { continue };
        for input in inputs_of(v) {
            if !kept.contains_key(&input) && all.get(&input.0).is_some_and(|vs| vs.iter().any(|v| v.number == input.1)) {
                kept.insert(input.clone(), format!("input of /{stage}/v{n}"));
                todo.push(input);
            }
        }
    }
    let mut out = Plan::default();
    for (stage, versions) in &all {
        for v in versions {
            match kept.get(&(stage.clone(), v.number)) {
                Some(why) => out.kept.push((stage.clone(), v.number, why.clone())),
                None => out.removed.push((stage.clone(), v.number)),
            }
        }
    }
    Ok(out)
}

/// Remove what `plan` removes, in one atomic commit with a `history` line. The archive
/// must be open for writing (its lock held).
pub fn apply(archive: &Archive, plan: &Plan) -> Result<()> {
    if plan.removed.is_empty() {
        return Ok(());
    }
    let file = super::open_hdf5(&archive.path)?;
    let title = match hdf::read_attrs(&file)?.remove("title") {
        Some(Attr::Str(t)) => t,
        _ => "laydown archive".to_string(),
    };
    drop(file);
    let names: Vec<String> = plan.removed.iter().map(|(s, n)| format!("/{s}/v{n}")).collect();
    let history = format!("{} laydown prune: removed {}", super::provenance::utc_now(), names.join(", "));
    let current = archive.current_marks()?;
    // The highest number of each stage that loses versions, so that none is reused.
    let mut highest: BTreeMap<&str, u32> = BTreeMap::new();
    for (stage, _) in &plan.removed {
        highest.insert(stage, archive.next_version(stage)? - 1);
    }
    archive.transaction(&title, &history, 0, |file| {
        for (stage, n) in &highest {
            let group = file.group(stage)?;
            if group.attr(super::HIGHEST_ATTR).is_ok() {
                group.delete_attr(super::HIGHEST_ATTR)?;
            }
            hdf::write_attr(&group, super::HIGHEST_ATTR, &Attr::I64(*n as i64))?;
        }
        for (stage, n) in &plan.removed {
            // Never a current version, whatever the plan says.
            if current.get(stage) == Some(n) {
                bail!("refusing to remove /{stage}/v{n}: it is current");
            }
            file.group(stage)?.unlink(&format!("v{n}")).with_context(|| format!("removing /{stage}/v{n}"))?;
        }
        Ok(())
    })?;
    // Their figure folders go too, once the versions are gone (numbers are never reused).
    for (stage, n) in &plan.removed {
        let dir = super::figure_dir(&archive.path, stage, *n);
        if dir.is_dir() {
            fs::remove_dir_all(&dir).with_context(|| format!("/{stage}/v{n} is removed, but not its figures in {}", dir.display()))?;
        }
    }
    Ok(())
}

/// Rewrite the archive into a new file holding only what it links to (giving back the
/// space of removed versions) and rename it over the archive, atomically. The archive
/// must be open for writing (its lock held). Returns the sizes before and after, in bytes.
pub fn repack(archive: &Archive) -> Result<(u64, u64)> {
    let before = fs::metadata(&archive.path)?.len();
    let partial = sibling(&archive.path, ".partial");
    let guard = PartialGuard::install(&partial);
    let result = write_repacked(archive, &partial)
        .and_then(|()| fs::rename(&partial, &archive.path).with_context(|| format!("renaming {} to {}", partial.display(), archive.path.display())));
    drop(guard);
    if let Err(e) = result {
        let _ = fs::remove_file(&partial);
        return Err(archive.explain_failure(e, 0));
    }
    if let Ok(d) = fs::File::open(archive.dir()) {
        let _ = d.sync_all();
    }
    Ok((before, fs::metadata(&archive.path)?.len()))
}

fn write_repacked(archive: &Archive, partial: &std::path::Path) -> Result<()> {
    use hdf5_sys::h5o::H5Ocopy;
    use hdf5_sys::h5p::H5P_DEFAULT;
    let src = super::open_hdf5(&archive.path)?;
    let dst = hdf5::File::create(partial).with_context(|| format!("creating {}", partial.display()))?;
    // Copied object by object; H5Ocopy leaves the dimension scales' references pointing
    // into the old file, so every version group's scales are attached anew afterwards.
    let mut copied = Ok(());
    for group in src.groups()? {
        let name = group.name().trim_start_matches('/').to_string();
        let c = std::ffi::CString::new(name.clone())?;
        let rc = hdf5::sync::sync(|| unsafe { H5Ocopy(src.id(), c.as_ptr(), dst.id(), c.as_ptr(), H5P_DEFAULT, H5P_DEFAULT) });
        if rc < 0 {
            copied = Err(anyhow!("copying /{name} into {} failed", partial.display()));
            break;
        }
        for version in group.member_names()? {
            let Ok(vg) = group.group(&version) else { continue };
            let dims = hdf::dimension_names(&vg)?;
            hdf::reattach_scales(&dst.group(&format!("{name}/{version}"))?, &dims).with_context(|| format!("/{name}/{version}"))?;
        }
    }
    copied?;
    for (k, v) in hdf::read_attrs(&src)? {
        hdf::write_attr(&dst, &k, &v)?;
    }
    drop(src);
    dst.flush()?;
    dst.close()?;
    fs::File::open(partial)?.sync_all()?;
    Ok(())
}

/// The stages and versions of a plan as text lines for the command line:
/// `remove /fibre/v2` per removed version (or `would remove` in a dry run).
pub fn describe(plan: &Plan, dry_run: bool) -> Vec<String> {
    let verb = if dry_run { "would remove" } else { "removed" };
    let mut lines: Vec<String> = plan.removed.iter().map(|(s, n)| format!("{verb} /{s}/v{n}")).collect();
    let kept_by_stage: BTreeSet<&str> = plan.kept.iter().map(|(s, _, _)| s.as_str()).collect();
    for stage in kept_by_stage {
        let vs: Vec<String> = plan.kept.iter().filter(|(s, _, _)| s == stage).map(|(_, n, why)| format!("v{n} ({why})")).collect();
        lines.push(format!("keep /{stage}: {}", vs.join(", ")));
    }
    lines
}
