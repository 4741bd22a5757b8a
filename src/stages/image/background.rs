//! Model of the broad central peak of the energy spectrum (the random fibre web).
//!
//! # Model
//! The spectrum is split into polar cells: annuli of width one frequency bin of the
//! shorter image side, `Δf = 1/min(H, W)` cycles per pixel, times `sectors` equal angular
//! sectors over the half plane (0 ≤ θ < π; the other half is the complex conjugate of a
//! real image). The background of a cell is the **median** of the raw power pooled over
//! that sector in neighbouring annuli (until `min_pool` bins, within ±17 % of the radius),
//! divided by ln 2. For a random field each periodogram bin is its local mean times an
//! Exp(1) variable, whose median is ln 2, so median/ln 2 estimates the local *mean* power
//! `E|F|²`, and the median ignores the few bond peaks in a pool. Sparse sectors (near the
//! centre, small images) pool all sectors. Each bin gets the value interpolated linearly
//! in radius and circularly in angle between cell centres, in the log domain.
//!
//! The standard error of the log background (`1/(ln2·√pool)`) is kept per bin; the
//! detector raises its threshold accordingly ([`corrected_threshold`]) so the
//! false-alarm rate holds although `B` is estimated.
//!
//! Sectors follow the anisotropy of real webs (fibres lie preferentially along the
//! machine direction, so the central peak is elongated), which a purely radial median
//! would turn into false alarms along one axis.
//!
//! # Divide, not subtract
//! The detector works on the **whitened** spectrum `W = |F|² / B` rather than on
//! `|F|² − B`. Speckle is multiplicative: the spread of the periodogram around `B` is
//! proportional to `B`, which spans many decades between the centre and the noise
//! plateau. After division `W ~ Exp(1)` everywhere the model holds, so one threshold
//! `t` has the known tail `P(W > t) = e^{−t}` at every radius and the false-alarm rate
//! is set by a single parameter. A subtracted spectrum would need a radius-dependent
//! threshold, which is the same thing done less directly.
use ndarray::Array2;

use super::fft2::signed_index;

/// Background (mean power) model of a spectrum, one value per frequency bin.
#[derive(Debug, Clone)]
pub struct Background {
    /// Estimated mean power `E|F|²` per bin, same layout as the spectrum (DC at [0, 0]).
    pub mean_power: Array2<f64>,
    /// Standard error of `ln(mean_power)` per bin (from the pool size of its cell).
    pub log_sd: Array2<f64>,
    /// Log of the pooled cell medians / ln 2, (annulus, sector).
    pub log_cells: Array2<f64>,
    /// Annulus width in cycles per pixel.
    pub annulus_width: f64,
}

/// Polar coordinates of bin (q, r) of an (h, w) spectrum: radius in annulus units and
/// angle in [0, 2π). The DC bin has radius 0.
pub fn polar(q: usize, r: usize, h: usize, w: usize) -> (f64, f64) {
    let fy = signed_index(q, h) as f64 / h as f64;
    let fx = signed_index(r, w) as f64 / w as f64;
    let df = 1.0 / h.min(w) as f64;
    let rad = (fx * fx + fy * fy).sqrt() / df;
    let th = fy.atan2(fx);
    let th = if th < 0.0 { th + 2.0 * std::f64::consts::PI } else { th };
    (rad, th)
}

/// True for the bins of the half plane 0 ≤ θ < π (excluding DC): each conjugate pair
/// (q, r) / (−q, −r) has exactly one member here, except self-conjugate Nyquist bins.
/// The Nyquist row (even `h`) and column (even `w`) are their own conjugates along that
/// axis and are treated like the axis itself.
pub fn in_half_plane(q: usize, r: usize, h: usize, w: usize) -> bool {
    let fy = signed_index(q, h);
    let fx = signed_index(r, w);
    let y_axis_like = fy == 0 || (h.is_multiple_of(2) && fy == -(h as isize) / 2);
    let x_axis_like = fx == 0 || (w.is_multiple_of(2) && fx == -(w as isize) / 2);
    if fy > 0 && !y_axis_like {
        return true;
    }
    if !y_axis_like {
        return false;
    }
    fx > 0 && !x_axis_like
}

fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    debug_assert!(n > 0);
    let (_, m, _) = v.select_nth_unstable_by(n / 2, |a, b| a.total_cmp(b));
    let hi = *m;
    if n % 2 == 1 {
        hi
    } else {
        let lo = v[..n / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lo + hi)
    }
}

/// Fits the background model to `power` (|F|², DC at [0, 0]).
///
/// For each (annulus n, sector s) the raw powers of the same sector in annuli
/// `n−k ..= n+k` are pooled, `k` growing from `min_halfwidth` until the pool holds
/// `min_pool` bins or `k` reaches `max(min_halfwidth, n/6)` (so the pool never spans more
/// than about ±17 % in radius). A sector still short of `min_pool/4` bins (near the
/// centre, or in small images) pools all sectors instead (purely radial there).
pub fn fit(power: &Array2<f64>, sectors: usize, min_halfwidth: usize, min_pool: usize) -> Background {
    fit_excluding(power, sectors, min_halfwidth, min_pool, None)
}

/// [`fit`] with the bins marked in `exclude` left out of every pool (the notched bond
/// peaks and their leakage ridges, whose power is not the web's): the cells' medians are
/// then those of the web alone, and every bin, excluded or not, still gets a value.
pub fn fit_excluding(power: &Array2<f64>, sectors: usize, min_halfwidth: usize, min_pool: usize, exclude: Option<&Array2<bool>>) -> Background {
    let (h, w) = power.dim();
    let sectors = sectors.max(1);
    let df = 1.0 / h.min(w) as f64;
    let pi = std::f64::consts::PI;
    // Largest radius (corner) in annulus units.
    let n_ann = ((0.5f64.hypot(0.5)) / df).ceil() as usize + 2;
    let mut cells: Vec<Vec<f64>> = vec![Vec::new(); n_ann * sectors];
    // Polar coordinates and cell of each bin (cached per shape).
    // Rows above h/2 are the conjugates of rows below: only rows 0..=h/2 are needed.
    let hh = h / 2 + 1;
    let lay = layout(h, w, sectors, n_ann);
    let geo = &lay.geo;
    for (k, &c) in lay.cell.iter().enumerate() {
        if c == u32::MAX || exclude.is_some_and(|e| e.as_slice().unwrap()[k]) {
            continue;
        }
        cells[c as usize].push(power.as_slice().unwrap()[k]);
    }
    let count = |n: usize, s: usize| cells[n * sectors + s].len();
    let tiny = f64::MIN_POSITIVE;
    let ln2 = std::f64::consts::LN_2;
    // One row of (log background, log sd) per annulus, in parallel; cells without bins
    // of their own are NaN here and filled from their neighbours below.
    use rayon::prelude::*;
    let rows: Vec<Vec<(f64, f64)>> = (0..n_ann)
        .into_par_iter()
        .map(|n| {
            let mut pool: Vec<f64> = Vec::new();
            let kmax = min_halfwidth.max(n / 6);
            let span = |k: usize| (n.saturating_sub(k).max(1.min(n)))..=((n + k).min(n_ann - 1));
            (0..sectors)
                .map(|s| {
                    if count(n, s) == 0 {
                        return (f64::NAN, f64::NAN);
                    }
                    let mut k = min_halfwidth;
                    let mut c: usize = span(k).map(|m| count(m, s)).sum();
                    while c < min_pool && k < kmax {
                        k += 1;
                        c = span(k).map(|m| count(m, s)).sum();
                    }
                    pool.clear();
                    if c * 4 >= min_pool {
                        for m in span(k) {
                            pool.extend_from_slice(&cells[m * sectors + s]);
                        }
                    } else {
                        // Too sparse: widen the angular window symmetrically (3, 5, …
                        // sectors), then, if still short, grow the radial window over all.
                        let merged = |hs: usize, k: usize| -> usize {
                            let sec = sector_window(s, hs, sectors);
                            span(k).map(|m| sec.iter().map(|&t| count(m, t)).sum::<usize>()).sum()
                        };
                        let mut half_s = 1usize;
                        while 2 * half_s + 1 < sectors && merged(half_s, kmax) * 4 < min_pool {
                            half_s += 1;
                        }
                        let mut k = min_halfwidth;
                        let kcap = if 2 * half_s + 1 >= sectors { n_ann } else { kmax };
                        while merged(half_s, k) < min_pool && k < kcap {
                            k += 1;
                        }
                        for m in span(k) {
                            for t in sector_window(s, half_s, sectors) {
                                pool.extend_from_slice(&cells[m * sectors + t]);
                            }
                        }
                    }
                    let med = median(&mut pool);
                    // Relative standard error of the median of Exp(1) samples: 1/(ln2·√n).
                    ((med / ln2).max(tiny).ln(), 1.0 / (ln2 * (pool.len() as f64).sqrt()))
                })
                .collect()
        })
        .collect();
    let mut log_cells = Array2::<f64>::from_shape_fn((n_ann, sectors), |(n, s)| rows[n][s].0);
    let mut log_sd = Array2::<f64>::from_shape_fn((n_ann, sectors), |(n, s)| rows[n][s].1);
    fill_empty(&mut log_cells, &mut log_sd, tiny.ln());
    // Per-bin interpolation (linear in radius and circularly in angle, in log), by rows.
    let mut mean_power = Array2::<f64>::zeros((h, w));
    let mut sd = Array2::<f64>::zeros((h, w));
    mean_power
        .as_slice_mut()
        .unwrap()
        .par_chunks_mut(w)
        .zip(sd.as_slice_mut().unwrap().par_chunks_mut(w))
        .enumerate()
        .for_each(|(q, (mrow, srow))| {
            if q >= hh {
                return;
            }
            for r in 0..w {
                // Folded to the half plane: the conjugate has the same power.
                let (rad, th) = geo[q * w + r];
                let n0 = (rad.floor() as usize).min(n_ann - 1);
                let n1 = (n0 + 1).min(n_ann - 1);
                let tr = (rad - n0 as f64).clamp(0.0, 1.0);
                let sp = th / pi * sectors as f64;
                let s0f = sp.floor();
                let ta = sp - s0f;
                let s0 = (s0f as usize) % sectors;
                let s1 = (s0 + 1) % sectors;
                let l = |a: &Array2<f64>, n: usize| (1.0 - ta) * a[[n, s0]] + ta * a[[n, s1]];
                mrow[r] = ((1.0 - tr) * l(&log_cells, n0) + tr * l(&log_cells, n1)).exp();
                srow[r] = (1.0 - tr) * l(&log_sd, n0) + tr * l(&log_sd, n1);
            }
        });
    for q in hh..h {
        for r in 0..w {
            let (cq, cr) = (h - q, (w - r) % w);
            mean_power[[q, r]] = mean_power[[cq, cr]];
            sd[[q, r]] = sd[[cq, cr]];
        }
    }
    Background { mean_power, log_sd: sd, log_cells, annulus_width: df }
}

/// Polar geometry of the half-plane rows `0..=h/2` of an (h, w) spectrum: per bin
/// (radius in annuli, angle folded to [0, π)) and its (annulus, sector) cell, `u32::MAX`
/// outside the half plane.
struct Layout {
    geo: Vec<(f64, f64)>,
    cell: Vec<u32>,
}

/// The [`Layout`] of a shape, cached (the two fits of an image, and images of one size,
/// share it; computing it costs about as much as the rest of a fit).
fn layout(h: usize, w: usize, sectors: usize, n_ann: usize) -> std::sync::Arc<Layout> {
    use std::collections::HashMap;
    use std::sync::{Arc, Mutex, OnceLock};
    static CACHE: OnceLock<Mutex<HashMap<(usize, usize, usize), Arc<Layout>>>> = OnceLock::new();
    let mut m = CACHE.get_or_init(|| Mutex::new(HashMap::new())).lock().unwrap_or_else(|e| e.into_inner());
    if m.len() > 8 {
        m.clear();
    }
    m.entry((h, w, sectors))
        .or_insert_with(|| {
            let pi = std::f64::consts::PI;
            let hh = h / 2 + 1;
            let mut geo = Vec::with_capacity(hh * w);
            let mut cell = Vec::with_capacity(hh * w);
            for q in 0..hh {
                for r in 0..w {
                    let (rad, th) = polar(q, r, h, w);
                    let th = if th >= pi { th - pi } else { th };
                    geo.push((rad, th));
                    cell.push(if in_half_plane(q, r, h, w) {
                        let n = (rad.round() as usize).min(n_ann - 1);
                        // Sectors are centred on θ = s·π/S, so one sits on each image axis (MD/CD).
                        let s = ((th / pi * sectors as f64 + 0.5) as usize) % sectors;
                        (n * sectors + s) as u32
                    } else {
                        u32::MAX
                    });
                }
            }
            Arc::new(Layout { geo, cell })
        })
        .clone()
}

/// Fills NaN cells from the nearest filled sector of the same annulus (circularly), or,
/// for an empty annulus, from the nearest filled annulus.
fn fill_empty(lc: &mut Array2<f64>, sd: &mut Array2<f64>, floor: f64) {
    let (na, ns) = lc.dim();
    for n in 0..na {
        for s in 0..ns {
            if !lc[[n, s]].is_nan() {
                continue;
            }
            let near = (1..=ns / 2)
                .flat_map(|d| [(s + d) % ns, (s + ns - d % ns) % ns])
                .find(|&t| !lc[[n, t]].is_nan());
            if let Some(t) = near {
                lc[[n, s]] = lc[[n, t]];
                sd[[n, s]] = sd[[n, t]];
            }
        }
    }
    for s in 0..ns {
        for n in 0..na {
            if lc[[n, s]].is_nan() {
                let src = (1..na).flat_map(|d| [n.checked_sub(d), Some(n + d)]).flatten().find(|&m| m < na && !lc[[m, s]].is_nan());
                let (v, e) = src.map(|m| (lc[[m, s]], sd[[m, s]])).unwrap_or((floor, 1.0));
                lc[[n, s]] = v;
                sd[[n, s]] = e;
            }
        }
    }
}

/// Sectors `s − hs ..= s + hs` (circular), or all sectors when that covers them all.
fn sector_window(s: usize, hs: usize, sectors: usize) -> Vec<usize> {
    if 2 * hs + 1 >= sectors {
        return (0..sectors).collect();
    }
    (0..=2 * hs).map(|d| (s + sectors + d - hs) % sectors).collect()
}

/// Threshold on `W = |F|²/B̂` giving the tail probability `e^{−t0}` of an exact `B`
/// when `B̂ = B·e^η` carries a log error `η ~ N(0, sd²)`:
/// `P(W > t) = E[exp(−t e^η)] ≈ exp(max_η(−t e^η − η²/2sd²))` (saddle point), solved for
/// `t` by bisection. Equals `t0` for `sd = 0`; about `t0 + t0²sd²/2` for small `sd`.
pub fn corrected_threshold(t0: f64, sd: f64) -> f64 {
    if !(sd > 0.0) {
        return t0;
    }
    let s2 = sd * sd;
    let log_tail = |t: f64| {
        // η* solves η + t s² e^η = 0 (Newton from 0; the function is increasing).
        let mut eta = 0.0f64;
        for _ in 0..50 {
            let g = eta + t * s2 * eta.exp();
            let dg = 1.0 + t * s2 * eta.exp();
            let step = g / dg;
            eta -= step;
            if step.abs() < 1e-12 {
                break;
            }
        }
        -t * eta.exp() - eta * eta / (2.0 * s2)
    };
    let (mut lo, mut hi) = (t0, t0 * 2.0);
    while log_tail(hi) > -t0 && hi < 1e6 {
        hi *= 2.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if log_tail(mid) > -t0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}


/// Per-bin detection threshold: `t` raised for the background's log error `log_sd` of
/// each flat bin index ([`corrected_threshold`]), interpolated from a table
/// over the log error.
pub fn corrected_thresholds(t: f64, log_sd: &Array2<f64>) -> impl Fn(usize) -> f64 + '_ {
    const STEP: f64 = 0.002;
    let max_sd = log_sd.iter().copied().fold(0.0, f64::max).min(5.0);
    let table: Vec<f64> = (0..=((max_sd / STEP).ceil() as usize + 1)).map(|i| corrected_threshold(t, i as f64 * STEP)).collect();
    let sd = log_sd.as_slice().unwrap();
    move |k: usize| {
        let x = sd[k].clamp(0.0, max_sd) / STEP;
        let i = (x.floor() as usize).min(table.len() - 2);
        let f = x - i as f64;
        (1.0 - f) * table[i] + f * table[i + 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Exp1};

    #[test]
    fn recovers_mean_of_exponential_speckle_on_a_steep_profile() {
        // Power = m(r) · Exp(1) with m falling by 6 decades: the model must return m(r).
        let (h, w) = (96, 128);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let m = |q: usize, r: usize| {
            let (rad, _) = polar(q, r, h, w);
            (-rad / 8.0).exp() * 1e6
        };
        let power = Array2::from_shape_fn((h, w), |(q, r)| {
            let e: f64 = Exp1.sample(&mut rng);
            m(q, r) * e
        });
        let bg = fit(&power, 8, 1, 256);
        let mut errs = Vec::new();
        for q in 0..h {
            for r in 0..w {
                let (rad, _) = polar(q, r, h, w);
                if rad > 6.0 && rad < 40.0 {
                    errs.push((bg.mean_power[[q, r]] / m(q, r)).ln().abs());
                }
            }
        }
        errs.sort_by(|a, b| a.total_cmp(b));
        let med = errs[errs.len() / 2];
        assert!(med < 0.1, "median log error {med}");
    }

    #[test]
    fn corrected_threshold_grows_with_the_background_error() {
        assert_eq!(corrected_threshold(20.0, 0.0), 20.0);
        let t = corrected_threshold(20.0, 0.05);
        // Small-error expansion t0 + t0²sd²/2 = 20.5.
        assert!((t - 20.5).abs() < 0.1, "{t}");
        assert!(corrected_threshold(20.0, 0.2) > 25.0);
    }

    #[test]
    fn half_plane_holds_one_of_each_conjugate_pair() {
        let (h, w) = (6, 7);
        for q in 0..h {
            for r in 0..w {
                let cq = (h - q) % h;
                let cr = (w - r) % w;
                if (q, r) == (cq, cr) {
                    continue;
                }
                assert!(in_half_plane(q, r, h, w) ^ in_half_plane(cq, cr, h, w), "({q},{r})");
            }
        }
    }
}
