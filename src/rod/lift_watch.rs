//! The paper's bounce test held over a window of end times (`bounce_check: last_period`).
//!
//! The paper rejects a replicate whose final profile has a landed node out of plane. At
//! process speeds (50 m/s) landed fibre rises in arches behind the touchdown and settles
//! again within a fraction of a millisecond, in step with the oscillation's sweep, so the
//! test at one end instant reads where in its sweep the run stops more than whether the
//! fibre lies flat (`pipelines/studies/FIBRE_SPEED.md`, "Arches come with the sweep").
//! A [`LiftWatch`] applies the same test after every accepted step of a window, the last
//! oscillation period of the run, and keeps the share of that time in which it would have
//! failed: the replicate is invalid when the fibre stood up for more than
//! [`LIFTED_MAJORITY`] of it, i.e. when the paper's test fails at most of the end
//! instants the window offers.
//!
//! ```
//! use laydown::rod::LiftWatch;
//! // watched from t = 1 s, tolerance 1 mm
//! let mut watch = LiftWatch::new(1.0, 1e-3);
//! watch.observe(0.5, || Some(5e-3)); // before the window: not counted (nor asked)
//! watch.observe(1.5, || Some(2e-3)); // [1, 1.5] lifted
//! watch.observe(2.0, || Some(0.0)); //  [1.5, 2] flat
//! watch.observe(3.0, || None); //       nothing landed: not watched
//! assert_eq!(watch.lifted_fraction(), 0.5);
//! assert!(!watch.bounced());
//! ```

/// The share of the watched window above which a replicate counts as bounced: more than
/// half, so that the verdict is the one the paper's test gives at most end instants.
pub const LIFTED_MAJORITY: f64 = 0.5;

/// Time in which the highest landed node stood above a tolerance, over a window that
/// starts at a given time. Plain data (`Copy`): a rollback restores it with the state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiftWatch {
    /// Start of the window (s).
    pub from: f64,
    /// Height above the belt (m) above which a landed node counts as lifted.
    pub tolerance: f64,
    last_time: f64,
    watched: f64,
    lifted: f64,
}

impl LiftWatch {
    /// A watch over the time after `from` (s) with the height `tolerance` (m).
    pub fn new(from: f64, tolerance: f64) -> Self {
        LiftWatch { from, tolerance, last_time: f64::NEG_INFINITY, watched: 0.0, lifted: 0.0 }
    }

    /// The state reached at time `t` (s), whose highest landed node is `highest_landed()`
    /// metres above the belt (None: no node has landed; asked only inside the window). The
    /// state at the end of a step stands for the time since the previous observation
    /// (within the window); a time in which nothing had landed is not watched.
    pub fn observe(&mut self, t: f64, highest_landed: impl FnOnce() -> Option<f64>) {
        let start = self.last_time.max(self.from);
        self.last_time = t;
        if t <= start {
            return;
        }
        if let Some(height) = highest_landed() {
            self.watched += t - start;
            if height > self.tolerance {
                self.lifted += t - start;
            }
        }
    }

    /// Time watched so far (s).
    pub fn watched(&self) -> f64 {
        self.watched
    }

    /// Share of the watched time in which a landed node stood above the tolerance
    /// (NaN: nothing watched, e.g. nothing landed within the window).
    pub fn lifted_fraction(&self) -> f64 {
        if self.watched > 0.0 {
            self.lifted / self.watched
        } else {
            f64::NAN
        }
    }

    /// True when landed fibre stood above the tolerance for more than
    /// [`LIFTED_MAJORITY`] of the watched time (never when nothing was watched).
    pub fn bounced(&self) -> bool {
        self.lifted_fraction() > LIFTED_MAJORITY
    }

    /// Why a replicate failed `bounce_check: last_period` (for [`Self::bounced`]).
    pub fn bounce_reason(&self) -> String {
        format!(
            "bounced: landed fibre stood above the belt by more than bounce_tolerance ({:.3e} m) for {:.0} % of the last oscillation period (more than {:.0} %, bounce_check last_period)",
            self.tolerance,
            100.0 * self.lifted_fraction(),
            100.0 * LIFTED_MAJORITY
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_wave_is_lifted_for_its_duty_cycle_in_time_not_in_steps() {
        // lifted in (0.25, 0.5] of each unit period, sampled 16 times as densely there
        // as elsewhere: a count of samples would read 0.84, the time 0.25
        let mut watch = LiftWatch::new(10.0, 1e-3);
        let mut t = 0.0f64;
        while t < 20.0 {
            let phase = t - t.floor();
            let lifted_next = (0.25..0.5).contains(&phase);
            t += if lifted_next { 1.0 / 512.0 } else { 1.0 / 32.0 };
            let phase = t - t.floor();
            let lifted = phase > 0.25 && phase <= 0.5;
            watch.observe(t, || Some(if lifted { 2e-3 } else { 5e-4 }));
        }
        assert!((watch.watched() - (t - 10.0)).abs() < 1e-12, "watched {}", watch.watched());
        assert!((watch.lifted_fraction() - 0.25).abs() < 1e-9, "share {}", watch.lifted_fraction());
        assert!(!watch.bounced());
    }

    #[test]
    fn nothing_landed_or_before_the_window_is_not_watched() {
        let mut watch = LiftWatch::new(1.0, 1e-3);
        watch.observe(0.9, || panic!("asked before the window"));
        watch.observe(1.2, || None);
        assert!(watch.lifted_fraction().is_nan());
        assert!(!watch.bounced());
        // the first interval after landing starts at the previous observation
        watch.observe(1.3, || Some(1.0));
        assert!((watch.watched() - 0.1).abs() < 1e-12);
        assert_eq!(watch.lifted_fraction(), 1.0);
        assert!(watch.bounced());
        assert!(watch.bounce_reason().contains("100 % of the last oscillation period"), "{}", watch.bounce_reason());
    }

    #[test]
    fn the_window_starts_inside_a_step() {
        let mut watch = LiftWatch::new(1.0, 1e-3);
        watch.observe(0.8, || Some(0.0));
        watch.observe(1.2, || Some(2e-3)); // only [1, 1.2] counts
        watch.observe(1.8, || Some(0.0));
        assert!((watch.watched() - 0.8).abs() < 1e-12);
        assert!((watch.lifted_fraction() - 0.25).abs() < 1e-12);
    }
}
