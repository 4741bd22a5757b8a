//! Hysteresis growth of the notches over the leakage ridges of the bond peaks.
//!
//! # Why
//! A bond harmonic whose period does not divide the image is not one bin but a peak
//! with **leakage ridges**: the spectrum of a tone at a fractional bin position spreads
//! along the row and the column of the spectrum through the peak (the DFT of the image
//! window is separable), decaying slowly (power roughly ∝ 1/d² at `d` bins, tens to
//! hundreds of times the web's power 10 bins away from a strong peak). A Gaussian notch
//! of a few bins leaves most of the ridge in place, and the ridge bins are not local
//! maxima, so the detector's passes find only a few of them. What is left is bond
//! pattern in the filtered image, i.e. a CV biased high; the ridge bins also inflate the
//! medians of the background pools they fall in, i.e. an over-estimate of the web
//! variance the compensation adds back.
//!
//! # Rule
//! From each detected peak's bin, the notch grows over **4-connected bins that are
//! themselves significant** in the whitened spectrum `W = |F|²/B`: `W > t_g`, with the
//! threshold raised per bin for the background's estimation error like the detector's
//! ([`super::background::corrected_threshold`]). It never enters the DC disc. The
//! growth threshold is the detector's false-alarm rule applied to the bins the growth
//! actually tests: every bin compared with the threshold is one test of the null (web
//! only) `P(W > t) = e^{−t}`, so with `n` bins tested `t_g = ln(n/α)` keeps the expected
//! number of web bins wrongly absorbed below `α` (`false_alarm_rate`). `n` is not known
//! before growing, so the growth runs twice: once at `ln(n₀/α)` with `n₀` the seeds'
//! first ring, then at `ln(n₁/α)` with `n₁` the bins tested by the first run; the
//! second region is contained in the first, so it tests at most `n₁` bins and the bound
//! holds. Because `n ≪ M` (the bins the detector searches) this threshold is lower
//! than the detector's, but the gain of the growth is mostly its connectivity: ridge
//! bins far above background that are not local maxima.
//!
//! Grown bins get gain 0 (with their conjugates, so the filtered image stays real).
//! Their web power is added back by the compensation from the background model like
//! the Gaussian notches' (`Σ(1 − g²)·B/N²`), with `B` refitted without the notched bins.
use ndarray::Array2;

use super::background::corrected_thresholds;
use super::fft2::{signed_index, wrap_index};

/// What the growth did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Growth {
    /// Bins added to the notches (both members of each conjugate pair counted).
    pub bins: usize,
    /// Bins the final growth compared with its threshold (those that joined included).
    pub tested: usize,
    /// Uncorrected threshold `t_g = ln(n/α)` of the final growth.
    pub threshold: f64,
}

/// Grows regions from `seeds` (storage bins (q, r)) over 4-connected bins with
/// `W = power/bg > threshold(k)` (`k` the flat bin index) outside the DC disc; returns
/// the region (full plane, conjugates included) and the number of bins tested.
fn flood(
    power: &Array2<f64>,
    bg: &Array2<f64>,
    seeds: &[(usize, usize)],
    threshold: &dyn Fn(usize) -> f64,
    dc_exclusion: f64,
) -> (Array2<bool>, usize) {
    let (h, w) = power.dim();
    let mut region = Array2::from_elem((h, w), false);
    let mut seen = Array2::from_elem((h, w), false);
    let mut stack: Vec<(usize, usize)> = Vec::new();
    let mut tested = 0usize;
    let radius = |q: usize, r: usize| (signed_index(q, h) as f64).hypot(signed_index(r, w) as f64);
    for &(q, r) in seeds {
        if !seen[[q, r]] {
            seen[[q, r]] = true;
            region[[q, r]] = true;
            stack.push((q, r));
        }
    }
    while let Some((q, r)) = stack.pop() {
        let (sq, sr) = (signed_index(q, h), signed_index(r, w));
        for (dq, dr) in [(-1isize, 0isize), (1, 0), (0, -1), (0, 1)] {
            let (nq, nr) = (wrap_index(sq + dq, h), wrap_index(sr + dr, w));
            if seen[[nq, nr]] {
                continue;
            }
            seen[[nq, nr]] = true;
            if radius(nq, nr) <= dc_exclusion {
                continue;
            }
            tested += 1;
            let k = nq * w + nr;
            let wv = power[[nq, nr]] / bg[[nq, nr]];
            if wv > threshold(k) {
                region[[nq, nr]] = true;
                stack.push((nq, nr));
            }
        }
    }
    // Conjugates: the power is Hermitian-symmetric, so the region mirrored is the region
    // grown from the conjugate seeds.
    for q in 0..h {
        for r in 0..w {
            if region[[q, r]] {
                region[[(h - q) % h, (w - r) % w]] = true;
            }
        }
    }
    (region, tested)
}

/// Hysteresis growth (module docs) from `seeds` over the whitened spectrum
/// `power / bg`, the threshold of each bin raised for the background's log error
/// `log_sd` ([`super::background::corrected_thresholds`]). Returns the grown region
/// (full plane, conjugates included; the seeds are in it) and what was done.
pub(crate) fn grow(power: &Array2<f64>, bg: &Array2<f64>, log_sd: &Array2<f64>, seeds: &[(usize, usize)], alpha: f64, dc_exclusion: f64) -> (Array2<bool>, Growth) {
    let t0 = ((4 * seeds.len()).max(1) as f64 / alpha).ln().max(1.0);
    let (_, n1) = flood(power, bg, seeds, &corrected_thresholds(t0, log_sd), dc_exclusion);
    let t1 = (n1.max(4 * seeds.len()).max(1) as f64 / alpha).ln().max(t0);
    let (region, tested) = flood(power, bg, seeds, &corrected_thresholds(t1, log_sd), dc_exclusion);
    let bins = region.iter().filter(|&&b| b).count();
    (region, Growth { bins, tested, threshold: t1 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grows_over_a_connected_ridge_and_stops_at_background() {
        // A peak at (5, 7) with a ridge along its column (rows 2..=12) above threshold,
        // an isolated strong bin elsewhere (not connected: not grown), background 1.
        let (h, w) = (32, 40);
        let mut p = Array2::from_elem((h, w), 1.0);
        for q in 2..=12 {
            p[[q, 7]] = 1e3;
        }
        p[[5, 7]] = 1e6;
        p[[20, 20]] = 1e6;
        let (bg, exact) = (Array2::from_elem((h, w), 1.0), Array2::zeros((h, w)));
        let (region, g) = grow(&p, &bg, &exact, &[(5, 7)], 1e-3, 2.0);
        for q in 2..=12 {
            assert!(region[[q, 7]], "ridge bin {q}");
            assert!(region[[(h - q) % h, (w - 7) % w]], "conjugate of ridge bin {q}");
        }
        assert!(!region[[1, 7]] && !region[[13, 7]] && !region[[5, 8]]);
        assert!(!region[[20, 20]], "unconnected bins are not grown");
        assert_eq!(g.bins, 22);
        // Tested: the 10 ridge bins besides the seed, and the ring around the ridge
        // (2 ends + 2 × 11 sides): every bin compared with the threshold counts.
        assert_eq!(g.tested, 34);
        assert!((g.threshold - (34.0f64 / 1e-3).ln()).abs() < 1e-12);
    }

    #[test]
    fn does_not_enter_the_dc_disc() {
        let (h, w) = (32, 32);
        let mut p = Array2::from_elem((h, w), 1.0);
        for r in 0..8 {
            p[[0, r]] = 1e4;
        }
        let (bg, exact) = (Array2::from_elem((h, w), 1.0), Array2::zeros((h, w)));
        let (region, _) = grow(&p, &bg, &exact, &[(0, 7)], 1e-3, 3.0);
        assert!(region[[0, 7]] && region[[0, 4]] && !region[[0, 3]] && !region[[0, 0]]);
    }
}
