//! Run time: what a stage's run is expected to cost in CPU time, from its parameters
//! alone, before anything is computed.
//!
//! A stage that can say ([`crate::stages::Stage::estimate_cpu_time`]; today `laid_web`,
//! whose webs with fibre contact run for hours, and `laydown`, whose explicit reference
//! at a fine mesh runs for minutes a replicate) estimates one replicate of each resolved
//! sweep point; a stage's total is the sum over its points times its replicates. Some
//! estimates are bounds (a laid web with fibre contact: "at least"; a laydown with the fed
//! start: "at most").
//! `laydown validate` prints every estimate, and `validate` and `run` with
//! `--max-cpu-time` refuse a pipeline with a stage above the limit (exit 2), naming the
//! stage, its estimate and the parameters that drive it. The wall time is about the CPU
//! time divided by the threads (the fibres of a web, and the webs, run in parallel).
use crate::pipeline::{Pipeline, StageDecl};

/// A stage's estimated CPU time.
#[derive(Debug, Clone, PartialEq)]
pub struct CpuEstimate {
    /// Index of the stage in the pipeline.
    pub stage: usize,
    /// Σ over its points and replicates (s).
    pub seconds: f64,
    /// Its points' bounds combined ([`crate::stages::Bound::of_sum`]).
    pub bound: crate::stages::Bound,
    /// What lowers it ([`crate::stages::CpuTime::advice`] of its costliest point).
    pub advice: String,
}

impl CpuEstimate {
    /// "about 15 min", "at least 45 min" or "at most 2 min".
    pub fn describe(&self) -> String {
        format!("{} {}", self.bound.words(), format_seconds(self.seconds))
    }
}

/// Every stage's estimated CPU time, for the stages that estimate it.
pub fn estimates(p: &Pipeline) -> Vec<CpuEstimate> {
    p.stages.iter().enumerate().filter_map(|(i, s)| stage_estimate(s, i)).collect()
}

fn stage_estimate(s: &StageDecl, stage: usize) -> Option<CpuEstimate> {
    let kind = crate::stages::find(&s.kind)?;
    let per_replicate: Option<Vec<_>> = s.points().0.iter().map(|p| kind.estimate_cpu_time(p)).collect();
    let per_replicate = per_replicate?;
    let seconds = per_replicate.iter().map(|e| e.seconds).sum::<f64>() * s.replicates as f64;
    let costliest = per_replicate.iter().max_by(|a, b| a.seconds.total_cmp(&b.seconds))?;
    Some(CpuEstimate {
        stage,
        seconds,
        bound: crate::stages::Bound::of_sum(per_replicate.iter().map(|e| e.bound)),
        advice: costliest.advice.clone(),
    })
}

/// A duration such as `90s`, `30min`, `2h`, `1.5d` or a plain number of seconds.
pub fn parse_duration(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = (&t[..split], t[split..].trim());
    let value: f64 = number.parse().map_err(|_| format!("`{text}` is not a duration: a number with a unit s, min, h or d, e.g. 30min"))?;
    let scale = match unit {
        "" | "s" => 1.0,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        "d" => 86400.0,
        _ => return Err(format!("`{text}`: unknown unit `{unit}` (allowed: s, min, h, d)")),
    };
    if !(value > 0.0) {
        return Err(format!("`{text}`: a duration must be positive"));
    }
    Ok(value * scale)
}

/// A CPU time for people: seconds, minutes or hours.
pub fn format_seconds(s: f64) -> String {
    if s < 10.0 {
        format!("{s:.1} s")
    } else if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.0} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

/// Of `estimates` (of `p`), the stages above `limit` CPU seconds, as
/// `error: file:line:col: message` lines (empty: none).
pub fn over_limit(p: &Pipeline, estimates: &[CpuEstimate], file: &str, limit: f64) -> Vec<String> {
    estimates
        .iter()
        .filter(|e| e.seconds > limit)
        .map(|e| {
            let s = &p.stages[e.stage];
            format!(
                "error: {file}:{}:{}: stages[{}]: stage `{}` ({}) is estimated at {} of CPU time ({} replicate(s) of {} point(s)), above --max-cpu-time {}; {}, or raise the limit",
                s.pos.line,
                s.pos.col,
                e.stage,
                s.name,
                s.kind,
                e.describe(),
                s.replicates,
                s.points().0.len(),
                format_seconds(limit),
                e.advice
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_parse_with_their_units_and_bad_ones_are_named() {
        assert_eq!(parse_duration("90").unwrap(), 90.0);
        assert_eq!(parse_duration("30min").unwrap(), 1800.0);
        assert_eq!(parse_duration("1.5h").unwrap(), 5400.0);
        assert_eq!(parse_duration("2d").unwrap(), 172800.0);
        assert!(parse_duration("3 weeks").unwrap_err().contains("unknown unit"));
        assert!(parse_duration("soon").unwrap_err().contains("not a duration"));
        assert!(parse_duration("0s").unwrap_err().contains("positive"));
    }
}
