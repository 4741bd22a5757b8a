//! Statistics over the images of a batch: per group means and standard deviations
//! ([`group_statistics`]) and the analysis of many files ([`analyze_files`]).

use std::path::{Path, PathBuf};

use super::*;

/// Mean and sample standard deviation (n − 1); std is 0 for a single value.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeanStd {
    pub mean: f64,
    pub std: f64,
}

impl MeanStd {
    pub fn of(v: &[f64]) -> MeanStd {
        let n = v.len();
        if n == 0 {
            return MeanStd { mean: 0.0, std: 0.0 };
        }
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = if n > 1 { (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt() } else { 0.0 };
        MeanStd { mean, std }
    }
}

/// Per-condition statistics over the samples of one group.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GroupStats {
    pub group: String,
    pub n: usize,
    pub cv_raw: MeanStd,
    pub cv_corr: MeanStd,
    pub cv_corr_plain: MeanStd,
    pub cv_corr_compensated: MeanStd,
    pub fraction_variance_removed: MeanStd,
    pub notch_count: MeanStd,
}

/// One analysed file of a batch.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SampleSummary {
    pub path: PathBuf,
    pub group: String,
    pub summary: Summary,
}

/// Results of a batch: per-file summaries (input order) and per-group statistics
/// (groups in order of first appearance).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BatchSummary {
    pub samples: Vec<SampleSummary>,
    pub groups: Vec<GroupStats>,
}

/// Groups (label, summary) pairs and computes mean and sample std per group.
pub fn group_statistics<'a>(samples: impl IntoIterator<Item = (&'a str, &'a Summary)>) -> Vec<GroupStats> {
    let mut groups: Vec<(String, Vec<&Summary>)> = Vec::new();
    for (g, s) in samples {
        match groups.iter_mut().find(|(name, _)| name == g) {
            Some((_, v)) => v.push(s),
            None => groups.push((g.to_string(), vec![s])),
        }
    }
    groups
        .into_iter()
        .map(|(group, v)| {
            let col = |f: &dyn Fn(&Summary) -> f64| MeanStd::of(&v.iter().map(|s| f(s)).collect::<Vec<_>>());
            GroupStats {
                n: v.len(),
                cv_raw: col(&|s| s.cv_raw),
                cv_corr: col(&|s| s.cv_corr),
                cv_corr_plain: col(&|s| s.cv_corr_plain),
                cv_corr_compensated: col(&|s| s.cv_corr_compensated),
                fraction_variance_removed: col(&|s| s.fraction_variance_removed),
                notch_count: col(&|s| s.notch_count as f64),
                group,
            }
        })
        .collect()
}

/// Expands `specs`, analyses each file in turn (stopping at the first error, which names
/// the file) and hands each full analysis to `sink` before dropping it, so a batch of
/// large scans never holds more than one analysis in memory.
pub fn analyze_files(
    specs: &[InputSpec],
    params: &ImageParams,
    mut sink: impl FnMut(&Path, &str, &ImageAnalysis),
) -> Result<BatchSummary, ImageError> {
    params.validate()?;
    let files = expand_inputs(specs)?;
    let mut samples = Vec::with_capacity(files.len());
    for (path, group) in files {
        let a = analyze_file(&path, params)?;
        sink(&path, &group, &a);
        samples.push(SampleSummary { summary: a.summary(), path, group });
    }
    let groups = group_statistics(samples.iter().map(|s| (s.group.as_str(), &s.summary)));
    Ok(BatchSummary { samples, groups })
}
