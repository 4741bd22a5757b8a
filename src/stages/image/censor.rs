//! Saturated (censored) pixels: the web under clipped bonds, restored from the lattice.
//!
//! # Why
//! A grey image saturates at black (0) and white (1). Where bright bonds on a bright
//! (thin) web exceed white, the pixel reads 1 whatever the web under it: the web's
//! value there is **censored** (only known to be above a level), not observed. A
//! notch filter cannot bring it back. On the synthetic strong, rotated and large-bond
//! lattices (6–9 % of the pixels clipped at 617 × 871 px) this, not the filter, was most
//! of the error of `cv_corr` (−1.6 to −2.9 %): the clipped pixels lose the web's
//! variance (the filtered image is smooth there, and what the notches take with the
//! clipped pattern is correlated with the web: −13 to −17 % of its variance), and the
//! clipped excess lowers the image mean (CV +0.8 to +1.7 %).
//!
//! # Model and estimator
//! The true grey level is `web(x) + b(x)`, `b` periodic on the fitted lattice, the web
//! independent of the lattice phase. Pixels are binned by their lattice phase (a
//! quarter pixel per bin along each lattice vector, see `phase_bins`). For a phase bin
//! φ with a fraction `p_hi` of its pixels at white and `p_lo` at black:
//! * **reference** distribution of the web: the first-pass filtered image at the phases
//!   without any censored pixel (if they hold less than 5 % of the pixels, the least
//!   censored phases, their uncensored pixels), interior only;
//! * **pattern level** `b_φ` by quantile matching: the uncensored pixels of φ are the web
//!   quantiles between `p_lo` and `1 − p_hi`, so their median matches the reference
//!   quantile `q = p_lo + (1 − p_lo − p_hi)/2`: `b_φ = median − Q_ref(q)`. With fewer
//!   than [`MIN_UNCENSORED`] uncensored pixels the censored fraction alone is matched
//!   (`P(web + b_φ > 1) = p_hi`, i.e. `b_φ = 1 − Q_ref(1 − p_hi)`; for black
//!   `b_φ = −Q_ref(p_lo)`); for a phase censored throughout this is only a bound: those
//!   phases are counted ([`Censoring::unresolved_phases`]) and warned about;
//! * **imputation**: a pixel clipped at white becomes `b_φ + E[web | web > 1 − b_φ]`,
//!   at black `b_φ + E[web | web < −b_φ]` (reference moments), and the conditional
//!   variance `Var[web | …]` it cannot show is kept per pixel.
//!
//! The imputed image is filtered with the same notches; its interior mean is the web's
//! (the clipped excess is back), and by the law of total variance the web's variance is
//! that of the filtered imputed image plus the mean conditional variance of the
//! imputed pixels (`censored_variance`), plus the compensation of the notches.
//!
//! The phases need an accurate lattice: [`super::peaks::fit_lattice`] weights the peaks
//! by their share of the variance, so aliased high harmonics do not pull the periods
//! (unweighted, a 12.02 px period came out as 12.00 px, 1.7 px of phase drift over 871 px,
//! which left the matched levels of the bond edges 0.03–0.07 low).
use ndarray::Array2;

use super::peaks::Lattice;

/// Uncensored pixels a phase bin needs for the quantile match.
pub const MIN_UNCENSORED: usize = 16;

/// Phase bins per pixel of lattice period (see `phase_bins`).
pub const PHASE_BINS_PER_PIXEL: f64 = 4.0;

/// Pixels a phase bin holds at least on average.
pub const MIN_PIXELS_PER_PHASE: f64 = 64.0;

/// About how many values of the reference are kept (evenly spaced in the image).
const REFERENCE_SAMPLE: usize = 1 << 16;

/// Smallest share of the pixels the reference distribution is drawn from.
const MIN_REFERENCE_SHARE: f64 = 0.05;

/// What the censoring correction found and did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Censoring {
    /// Fraction of the pixels at 0 or 1 (whole image).
    pub fraction: f64,
    /// Phase bins (per lattice vector product).
    pub phases: usize,
    /// Phase bins censored in all their pixels, whose level is only bounded.
    pub unresolved_phases: usize,
    /// The image with its censored pixels replaced by their conditional means.
    pub imputed: Array2<f64>,
    /// Conditional variance of each imputed pixel (0 elsewhere).
    pub conditional_variance: Array2<f64>,
}

/// Which pixels are censored: with grey levels in [0, 1], those at exactly 0 (black) or
/// 1 (white). `None` when no pixel is (or the image is not on that scale).
pub fn censored(raw: &Array2<f64>) -> Option<Array2<i8>> {
    let (lo, hi) = raw.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if !(lo >= 0.0 && hi <= 1.0) || lo == hi {
        return None;
    }
    let c = raw.mapv(|v| if v >= 1.0 { 1i8 } else if v <= 0.0 { -1 } else { 0 });
    c.iter().any(|&v| v != 0).then_some(c)
}

/// Lattice phase bin of every pixel: phase `frac(b_i · x)` along each fitted reciprocal
/// vector `b_i` (`x` the pixel position, m), in `n_i = ⌈r·period_i/pixel⌉` bins, i.e.
/// `r` bins per pixel of period. `r` = [`PHASE_BINS_PER_PIXEL`] (quarter-pixel bins: at a
/// bond edge the level changes by up to the full contrast over one pixel of phase, and
/// pixels at different levels in one bin would bias its matched level), lowered so
/// that a bin holds at least [`MIN_PIXELS_PER_PHASE`] pixels on average.
fn phase_bins(h: usize, w: usize, pixel: f64, lattice: &Lattice) -> (Array2<u32>, usize) {
    let cell_px: f64 = lattice.periods.iter().map(|p| p / pixel).product();
    let fit = ((h * w) as f64 / (MIN_PIXELS_PER_PHASE * cell_px)).powf(1.0 / lattice.periods.len().max(1) as f64);
    let res = PHASE_BINS_PER_PIXEL.min(fit).max(1e-3);
    let dims: Vec<usize> = lattice.periods.iter().map(|p| ((res * p / pixel).ceil() as usize).clamp(2, 1024)).collect();
    let total = dims.iter().product::<usize>();
    let mut bins = Array2::<u32>::zeros((h, w));
    use rayon::prelude::*;
    bins.as_slice_mut().unwrap().par_chunks_mut(w).enumerate().for_each(|(i, row)| {
        let y = i as f64 * pixel;
        for (j, out) in row.iter_mut().enumerate() {
            let x = j as f64 * pixel;
            let mut idx = 0usize;
            for (b, &n) in lattice.reciprocal.iter().zip(&dims) {
                let f = b[0] * x + b[1] * y;
                let f = f - f.floor();
                idx = idx * n + ((f * n as f64) as usize).min(n - 1);
            }
            *out = idx as u32;
        }
    });
    (bins, total)
}

/// Sorted sample with prefix sums for conditional moments and quantiles.
struct Reference {
    v: Vec<f64>,
    /// Prefix sums of v and v².
    s1: Vec<f64>,
    s2: Vec<f64>,
}

impl Reference {
    fn new(mut v: Vec<f64>) -> Self {
        v.sort_by(|a, b| a.total_cmp(b));
        let mut s1 = vec![0.0; v.len() + 1];
        let mut s2 = vec![0.0; v.len() + 1];
        for (k, x) in v.iter().enumerate() {
            s1[k + 1] = s1[k] + x;
            s2[k + 1] = s2[k] + x * x;
        }
        Reference { v, s1, s2 }
    }
    fn quantile(&self, q: f64) -> f64 {
        let n = self.v.len();
        self.v[((q * n as f64) as usize).min(n - 1)]
    }
    /// Mean and variance of the values in index range a..b (at least one value).
    fn moments(&self, a: usize, b: usize) -> (f64, f64) {
        let (a, b) = (a.min(self.v.len() - 1), b.max(a + 1).min(self.v.len()));
        let (a, b) = if b > a { (a, b) } else { (b - 1, b) };
        let c = (b - a) as f64;
        let m = (self.s1[b] - self.s1[a]) / c;
        (m, ((self.s2[b] - self.s2[a]) / c - m * m).max(0.0))
    }
    /// Moments of the values above `t` (the largest one if none is).
    fn above(&self, t: f64) -> (f64, f64) {
        let k = self.v.partition_point(|&x| x <= t);
        self.moments(k, self.v.len())
    }
    /// Moments of the values below `t` (the smallest one if none is).
    fn below(&self, t: f64) -> (f64, f64) {
        let k = self.v.partition_point(|&x| x < t);
        self.moments(0, k)
    }
}

/// The correction (module docs): `raw` the image, `cens` from [`censored`], `filtered`
/// the first-pass notch-filtered image, `margin` the edge band left out of the reference.
pub fn correct(raw: &Array2<f64>, cens: &Array2<i8>, filtered: &Array2<f64>, pixel: f64, lattice: &Lattice, margin: usize) -> Censoring {
    let (h, w) = raw.dim();
    let (bins, nb) = phase_bins(h, w, pixel, lattice);
    let mut count = vec![0usize; nb];
    let mut hi = vec![0usize; nb];
    let mut lo = vec![0usize; nb];
    for (&b, &c) in bins.iter().zip(cens.iter()) {
        let b = b as usize;
        count[b] += 1;
        match c {
            1 => hi[b] += 1,
            -1 => lo[b] += 1,
            _ => {}
        }
    }
    let frac = |b: usize| (hi[b] + lo[b]) as f64 / count[b].max(1) as f64;
    // Reference phases: uncensored ones, or the least censored until they hold 5 %.
    let mut order: Vec<usize> = (0..nb).filter(|&b| count[b] > 0).collect();
    order.sort_by(|&a, &b| frac(a).total_cmp(&frac(b)));
    let mut is_ref = vec![false; nb];
    let mut held = 0usize;
    for &b in &order {
        if frac(b) > 0.0 && held as f64 >= MIN_REFERENCE_SHARE * (h * w) as f64 {
            break;
        }
        is_ref[b] = true;
        held += count[b];
    }
    let interior = |i: usize, j: usize| i >= margin && i + margin < h && j >= margin && j + margin < w;
    let mut sample = Vec::new();
    for ((i, j), &f) in filtered.indexed_iter() {
        if is_ref[bins[[i, j]] as usize] && cens[[i, j]] == 0 && interior(i, j) {
            sample.push(f);
        }
    }
    if sample.len() > 2 * REFERENCE_SAMPLE {
        // Every k-th value is plenty for quantiles and tail moments (and sorts faster).
        let k = sample.len() / REFERENCE_SAMPLE;
        sample = sample.into_iter().step_by(k).collect();
    }
    if sample.len() < MIN_UNCENSORED {
        // (A tiny image) the uncensored pixels wherever they are.
        sample = filtered.iter().zip(cens.iter()).filter(|(_, &c)| c == 0).map(|(&f, _)| f).collect();
    }
    let reference = Reference::new(sample);
    // Uncensored values of the phases that need a level.
    let mut unc: Vec<Vec<f64>> = vec![Vec::new(); nb];
    for ((&b, &c), &v) in bins.iter().zip(cens.iter()).zip(raw.iter()) {
        let b = b as usize;
        if c == 0 && hi[b] + lo[b] > 0 {
            unc[b].push(v);
        }
    }
    let mut level = vec![f64::NAN; nb];
    let mut unresolved = 0usize;
    for b in 0..nb {
        if hi[b] + lo[b] == 0 {
            continue;
        }
        let (ph, pl) = (hi[b] as f64 / count[b] as f64, lo[b] as f64 / count[b] as f64);
        let u = &mut unc[b];
        level[b] = if u.len() >= MIN_UNCENSORED {
            let k = u.len() / 2;
            let (_, med, _) = u.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
            *med - reference.quantile(pl + (1.0 - pl - ph) / 2.0)
        } else {
            if u.is_empty() {
                unresolved += 1;
            }
            if ph >= pl { 1.0 - reference.quantile(1.0 - ph) } else { -reference.quantile(pl) }
        };
    }
    let mut imputed = raw.clone();
    let mut conditional_variance = Array2::<f64>::zeros((h, w));
    for ((i, j), v) in imputed.indexed_iter_mut() {
        let c = cens[[i, j]];
        if c == 0 {
            continue;
        }
        let b = level[bins[[i, j]] as usize];
        let (m, var) = if c > 0 { reference.above(1.0 - b) } else { reference.below(-b) };
        *v = b + m;
        conditional_variance[[i, j]] = var;
    }
    let n_cens = cens.iter().filter(|&&c| c != 0).count();
    Censoring { fraction: n_cens as f64 / (h * w) as f64, phases: nb, unresolved_phases: unresolved, imputed, conditional_variance }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(period: f64) -> Lattice {
        Lattice {
            reciprocal: vec![[1.0 / period, 0.0], [0.0, 1.0 / period]],
            basis: vec![[period, 0.0], [0.0, period]],
            periods: vec![period, period],
            angles_deg: vec![0.0, 90.0],
            angle_between_deg: Some(90.0),
            explained: 0,
            rms_residual: 0.0,
        }
    }

    #[test]
    fn restores_the_mean_and_variance_of_a_clipped_periodic_pattern() {
        use rand::{Rng, SeedableRng};
        // Web: independent uniform levels in [0.5, 0.9] (mean 0.7, variance 0.4²/12);
        // bonds: +0.35 on a 2×2 px spot of every 8×8 px cell, clipped at 1 where the
        // web is above 0.65 (most of them).
        let (h, w, px) = (160, 200, 1e-4);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let web = Array2::from_shape_fn((h, w), |_| 0.5 + 0.4 * rng.random::<f64>());
        let bond = Array2::from_shape_fn((h, w), |(i, j)| if i % 8 < 2 && j % 8 < 2 { 0.35 } else { 0.0 });
        let truth = &web + &bond;
        let raw = truth.mapv(|v| v.min(1.0));
        let cens = censored(&raw).unwrap();
        let f = cens.iter().filter(|&&c| c != 0).count() as f64 / (h * w) as f64;
        assert!(f > 0.03, "{f}");
        // A perfect first pass: the web itself as the filtered image.
        let c = correct(&raw, &cens, &web, px, &lattice(8.0 * px), 0);
        assert_eq!(c.unresolved_phases, 0);
        // Quarter-pixel bins would hold 32000/32² ≈ 31 pixels: coarser, 23 per period.
        assert_eq!(c.phases, 23 * 23);
        let mean = |a: &Array2<f64>| a.mean().unwrap();
        let imputed_web = &c.imputed - &bond;
        let var = |a: &Array2<f64>| a.mapv(|v| v * v).mean().unwrap() - mean(a).powi(2);
        let var_total = var(&imputed_web) + c.conditional_variance.mean().unwrap();
        assert!((mean(&c.imputed) / mean(&truth) - 1.0).abs() < 1e-3, "{} vs {}", mean(&c.imputed), mean(&truth));
        assert!((var_total / var(&web) - 1.0).abs() < 0.03, "{var_total} vs {}", var(&web));
        // Without the correction the clipped image is well off.
        assert!(mean(&raw) < mean(&truth) - 0.004, "{} vs {}", mean(&raw), mean(&truth));
    }

    #[test]
    fn no_censoring_off_the_unit_scale_or_without_extreme_pixels() {
        assert!(censored(&Array2::from_shape_fn((4, 4), |(i, j)| 0.2 + 0.01 * (i + j) as f64)).is_none());
        assert!(censored(&Array2::from_shape_fn((4, 4), |(i, j)| 1.0 + (i + j) as f64)).is_none());
        let mut a = Array2::from_elem((4, 4), 0.5);
        a[[1, 2]] = 1.0;
        a[[2, 2]] = 0.0;
        let c = censored(&a).unwrap();
        assert_eq!((c[[1, 2]], c[[2, 2]], c[[0, 0]]), (1, -1, 0));
    }
}
