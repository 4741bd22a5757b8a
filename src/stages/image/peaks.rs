//! Detection of sharp spectral peaks (the bond lattice) and fit of a 2D lattice to them.
//!
//! # Detector
//! A bin is a peak candidate when, in the whitened spectrum `W = |F|²/B` (see
//! [`super::background`]),
//! 1. `W > t` with `t = ln(M·passes/α)`: under the null (no bond) `W ~ Exp(1)`, so
//!    `P(W > t) = e^{−t}`, and with `M` bins searched per pass (half plane outside the DC
//!    disc) the expected number of false peaks per image is at most `α`
//!    (`false_alarm_rate`, Bonferroni);
//! 2. it lies outside the DC disc of radius `dc_exclusion_bins` (in bin-index units);
//! 3. its excess power `2(|F|² − B)` is at least `min_peak_fraction` of the image's
//!    variance (Σ over non-DC bins of |F|²). This restricts the search to bins well above
//!    the noise floor: a bin below it cannot change the CV noticeably, and blurred or
//!    noise-free synthetic images, whose far tail is round-off, are no longer searched;
//! 4. it is a local maximum of `W` over its 3×3 neighbourhood (one candidate per peak).
//!
//! The peak frequency is refined to a fraction of a bin from the magnitudes of the two
//! neighbours along each axis (exact for an isolated rectangular-window tone).
use ndarray::Array2;
use num_complex::Complex64;

use super::background::in_half_plane;
use super::fft2::{signed_index, wrap_index};

/// One detected spectral peak (the half-plane member of a conjugate pair).
#[derive(Debug, Clone, PartialEq)]
pub struct Peak {
    /// Spatial frequency along x (image columns), cycles per metre.
    pub kx: f64,
    /// Spatial frequency along y (image rows, downwards), cycles per metre.
    pub ky: f64,
    /// Refined signed bin index along x (columns).
    pub u: f64,
    /// Refined signed bin index along y (rows).
    pub v: f64,
    /// Period 1/|k| of the fringes, metres.
    pub period: f64,
    /// Direction of the wave vector, degrees from +x towards +y, in [0, 180).
    pub angle_deg: f64,
    /// Whitened strength W = |F|²/B at the peak bin (multiples of the local background).
    pub strength: f64,
    /// Share of the image variance in this peak and its conjugate: 2(|F|² − B)/Σ_{AC}|F|².
    pub variance_fraction: f64,
    /// Notch width used, bins.
    pub notch_sigma: f64,
    /// Detection pass (0 = first).
    pub pass: usize,
    /// Lattice indices (m, n) when the peak is explained by the fitted lattice.
    pub lattice_index: Option<[i32; 2]>,
}

/// Candidate bins found in one pass: (q, r) storage indices, sorted by decreasing W.
pub(crate) struct Candidate {
    pub q: usize,
    pub r: usize,
    pub w: f64,
    pub power: f64,
    pub bg: f64,
}

pub(crate) struct SearchSpace {
    pub threshold: f64,
    pub bins: usize,
}

/// Threshold `t = ln(M·passes/α)` and bin count `M` of the search region.
pub(crate) fn search_space(h: usize, w: usize, dc_exclusion: f64, passes: usize, alpha: f64) -> SearchSpace {
    // Half-plane bins (one of each conjugate pair; self-conjugate bins excluded) minus
    // those inside the DC disc, which only needs a scan of the disc's bounding box.
    let self_conj = (1 + usize::from(h.is_multiple_of(2))) * (1 + usize::from(w.is_multiple_of(2)));
    let half = (h * w - self_conj) / 2;
    let reach = dc_exclusion.floor() as isize;
    let mut inside = 0usize;
    let mut seen = std::collections::HashSet::new();
    for dq in -reach..=reach {
        for dr in -reach..=reach {
            let (q, r) = (wrap_index(dq, h), wrap_index(dr, w));
            if seen.insert((q, r)) && in_half_plane(q, r, h, w) && bin_radius(q, r, h, w) <= dc_exclusion {
                inside += 1;
            }
        }
    }
    let m = half.saturating_sub(inside);
    let threshold = ((m.max(1) * passes.max(1)) as f64 / alpha).ln().max(1.0);
    SearchSpace { threshold, bins: m }
}

/// Distance of bin (q, r) from DC in bin-index units.
pub(crate) fn bin_radius(q: usize, r: usize, h: usize, w: usize) -> f64 {
    (signed_index(q, h) as f64).hypot(signed_index(r, w) as f64)
}

/// Finds candidates in the notched power `power·gain²` against background `bg`.
/// `threshold(k)` gives the (error-corrected) threshold of flat bin index `k`; it is
/// only called for bins above `t0`, its lower bound. `taken` marks bins already used.
#[allow(clippy::too_many_arguments)]
pub(crate) fn find_candidates(
    power: &Array2<f64>,
    gain: &Array2<f64>,
    bg: &Array2<f64>,
    total_ac: f64,
    t0: f64,
    threshold: &dyn Fn(usize) -> f64,
    dc_exclusion: f64,
    min_fraction: f64,
    taken: &Array2<bool>,
) -> Vec<Candidate> {
    let (h, w) = power.dim();
    let (ps, gs, bs) = (power.as_slice().unwrap(), gain.as_slice().unwrap(), bg.as_slice().unwrap());
    let white = |k: usize| ps[k] * gs[k] * gs[k] / bs[k];
    let mut out = Vec::new();
    // The half plane lies in rows 0..=h/2.
    for q in 0..=(h / 2).min(h - 1) {
        for r in 0..w {
            let k = q * w + r;
            let wv = white(k);
            if !(wv > t0) {
                continue;
            }
            if !in_half_plane(q, r, h, w) || taken[[q, r]] || !(wv > threshold(k)) {
                continue;
            }
            if bin_radius(q, r, h, w) <= dc_exclusion {
                continue;
            }
            let pk = ps[k] * gs[k] * gs[k];
            let excess = 2.0 * (pk - bs[k]);
            if !(excess >= min_fraction * total_ac) {
                continue;
            }
            let sq = signed_index(q, h);
            let sr = signed_index(r, w);
            let mut is_max = true;
            'nb: for dq in -1..=1isize {
                for dr in -1..=1isize {
                    if dq == 0 && dr == 0 {
                        continue;
                    }
                    let nq = wrap_index(sq + dq, h);
                    let nr = wrap_index(sr + dr, w);
                    if (nq, nr) == (q, r) {
                        continue;
                    }
                    let nv = white(nq * w + nr);
                    // Ties broken by position so a flat-topped peak yields one candidate.
                    if nv > wv || (nv == wv && (nq, nr) < (q, r)) {
                        is_max = false;
                        break 'nb;
                    }
                }
            }
            if is_max {
                out.push(Candidate { q, r, w: wv, power: pk, bg: bs[k] });
            }
        }
    }
    out.sort_by(|a, b| b.w.total_cmp(&a.w));
    out
}

/// Sub-bin offset of a peak from the magnitudes at −1, 0, +1 along one axis, in [−0.5, 0.5].
pub(crate) fn sub_bin_offset(m_minus: f64, m0: f64, m_plus: f64) -> f64 {
    let d = if m_plus > m_minus {
        let s = m0 + m_plus;
        if s > 0.0 { m_plus / s } else { 0.0 }
    } else {
        let s = m0 + m_minus;
        if s > 0.0 { -m_minus / s } else { 0.0 }
    };
    if d.is_finite() { d.clamp(-0.5, 0.5) } else { 0.0 }
}

/// Refined signed (v, u) position of the peak at storage bin (q, r) of `spec·gain`.
pub(crate) fn refine(spec: &Array2<Complex64>, gain: &Array2<f64>, q: usize, r: usize) -> (f64, f64) {
    let (h, w) = spec.dim();
    let sq = signed_index(q, h);
    let sr = signed_index(r, w);
    let m = |dq: isize, dr: isize| {
        let (a, b) = (wrap_index(sq + dq, h), wrap_index(sr + dr, w));
        spec[[a, b]].norm() * gain[[a, b]]
    };
    let dv = if h >= 3 { sub_bin_offset(m(-1, 0), m(0, 0), m(1, 0)) } else { 0.0 };
    let du = if w >= 3 { sub_bin_offset(m(0, -1), m(0, 0), m(0, 1)) } else { 0.0 };
    (sq as f64 + dv, sr as f64 + du)
}

/// A lattice fitted to the detected peaks.
#[derive(Debug, Clone, PartialEq)]
pub struct Lattice {
    /// Reciprocal basis vectors (cycles/m), one (line pattern) or two; reduced (shortest).
    pub reciprocal: Vec<[f64; 2]>,
    /// Real-space basis vectors (m), dual to `reciprocal` (a_i · b_j = δ_ij); for one
    /// vector, the fringe-normal vector of length = period.
    pub basis: Vec<[f64; 2]>,
    /// Lengths of the real-space basis vectors: the bond repeat distances (m).
    pub periods: Vec<f64>,
    /// Directions of the real-space basis vectors, degrees from +x towards +y, in [0, 180).
    pub angles_deg: Vec<f64>,
    /// Angle between the two real-space basis vectors, degrees (None for one vector).
    pub angle_between_deg: Option<f64>,
    /// Peaks explained as integer combinations of the reciprocal basis.
    pub explained: usize,
    /// RMS distance of the explained peaks from their lattice points (cycles/m).
    pub rms_residual: f64,
}

const INDEX_TOL: f64 = 0.2;

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
fn angle_deg(a: [f64; 2]) -> f64 {
    a[1].atan2(a[0]).to_degrees().rem_euclid(180.0)
}

/// Integer indices of `k` in basis (a, b) if within tolerance.
fn indices(k: [f64; 2], a: [f64; 2], b: [f64; 2]) -> Option<[i32; 2]> {
    let det = cross(a, b);
    let m = cross(k, b) / det;
    let n = cross(a, k) / det;
    let (mr, nr) = (m.round(), n.round());
    if (m - mr).abs() < INDEX_TOL && (n - nr).abs() < INDEX_TOL && mr.abs() < 1e4 && nr.abs() < 1e4 {
        Some([mr as i32, nr as i32])
    } else {
        None
    }
}

/// Index of `k` along a single vector `a` (collinear patterns).
fn index1(k: [f64; 2], a: [f64; 2]) -> Option<i32> {
    let aa = dot(a, a);
    let m = dot(k, a) / aa;
    let perp = cross(a, k).abs() / aa.sqrt();
    let mr = m.round();
    if (m - mr).abs() < INDEX_TOL && perp < INDEX_TOL * aa.sqrt() && mr != 0.0 {
        Some(mr as i32)
    } else {
        None
    }
}

/// Dual basis: (a1, a2) with a_i · b_j = δ_ij (symmetric: the dual of the dual is the basis).
fn dual(b1: [f64; 2], b2: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let det = cross(b1, b2);
    ([b2[1] / det, -b2[0] / det], [-b1[1] / det, b1[0] / det])
}

/// Gauss–Lagrange reduction of a 2D basis to its two shortest independent vectors.
fn reduce(mut a: [f64; 2], mut b: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    for _ in 0..64 {
        if dot(a, a) > dot(b, b) {
            std::mem::swap(&mut a, &mut b);
        }
        let mu = (dot(a, b) / dot(a, a)).round();
        if mu == 0.0 {
            break;
        }
        b = [b[0] - mu * a[0], b[1] - mu * a[1]];
    }
    if dot(a, a) > dot(b, b) {
        std::mem::swap(&mut a, &mut b);
    }
    (a, b)
}

/// Fits a lattice to the peaks (their wave vectors and conjugates), assigning each peak's
/// `lattice_index`. Candidate bases are pairs of the `max_basis_candidates` strongest
/// peaks; the pair explaining the most peak strength wins (ties: smaller cell), then it
/// is reduced and refined by least squares on all explained peaks.
pub fn fit_lattice(peaks: &mut [Peak], max_basis_candidates: usize) -> Option<Lattice> {
    if peaks.is_empty() {
        return None;
    }
    let ks: Vec<[f64; 2]> = peaks.iter().map(|p| [p.kx, p.ky]).collect();
    let wts: Vec<f64> = peaks.iter().map(|p| p.variance_fraction.max(1e-12)).collect();
    let mut order: Vec<usize> = (0..peaks.len()).collect();
    order.sort_by(|&i, &j| wts[j].total_cmp(&wts[i]));
    let cand: Vec<[f64; 2]> = order.iter().take(max_basis_candidates).map(|&i| ks[i]).collect();
    let kscale = ks.iter().map(|k| dot(*k, *k).sqrt()).fold(0.0, f64::max);
    // Two-vector bases.
    let mut best: Option<(f64, f64, [f64; 2], [f64; 2])> = None;
    for i in 0..cand.len() {
        for j in i + 1..cand.len() {
            for sgn in [1.0, -1.0] {
                let a = cand[i];
                let b = [sgn * cand[j][0], sgn * cand[j][1]];
                let area = cross(a, b).abs();
                if area < 1e-3 * kscale * kscale {
                    continue;
                }
                let (a, b) = reduce(a, b);
                let score: f64 = ks.iter().zip(&wts).filter(|(k, _)| indices(**k, a, b).is_some()).map(|(_, w)| *w).sum();
                let better = match &best {
                    None => true,
                    Some((s, ar, _, _)) => score > *s * (1.0 + 1e-9) || ((score - *s).abs() <= 1e-9 * s && area < *ar),
                };
                if better {
                    best = Some((score, area, a, b));
                }
            }
        }
    }
    // One-vector basis (all peaks collinear, e.g. stripes) if it explains at least as much.
    let mut best1: Option<(f64, [f64; 2])> = None;
    for &a in &cand {
        // Use the shortest vector collinear with `a` among the peaks as the fundamental.
        let mut a = a;
        for k in &ks {
            if cross(a, *k).abs() < 1e-3 * dot(a, a) && dot(*k, *k) < dot(a, a) {
                a = if dot(a, *k) >= 0.0 { *k } else { [-k[0], -k[1]] };
            }
        }
        let score: f64 = ks.iter().zip(&wts).filter(|(k, _)| index1(**k, a).is_some()).map(|(_, w)| *w).sum();
        if best1.as_ref().is_none_or(|(s, _)| score > *s) {
            best1 = Some((score, a));
        }
    }
    let use_two = match (&best, &best1) {
        (Some((s2, ..)), Some((s1, _))) => *s2 > *s1 * (1.0 + 1e-9),
        (Some(_), None) => true,
        _ => false,
    };
    if use_two {
        let (_, _, a, b) = best.unwrap();
        // Least squares: k ≈ m a + n b over explained peaks, weighted by their share of
        // the variance. Unweighted, the many weak high harmonics dominate, and those of
        // sharp bonds are aliased (beyond Nyquist) next to lower ones: for a 12.02 px
        // period they pulled the fit to 12.00 px, a phase drift of 1.7 px over 871 px.
        let idx: Vec<Option<[i32; 2]>> = ks.iter().map(|k| indices(*k, a, b)).collect();
        let (mut smm, mut smn, mut snn) = (0.0, 0.0, 0.0);
        let (mut skm, mut skn) = ([0.0; 2], [0.0; 2]);
        for ((k, ix), &wt) in ks.iter().zip(&idx).zip(&wts) {
            if let Some([m, n]) = ix {
                let (m, n) = (*m as f64, *n as f64);
                smm += wt * m * m;
                smn += wt * m * n;
                snn += wt * n * n;
                for c in 0..2 {
                    skm[c] += wt * k[c] * m;
                    skn[c] += wt * k[c] * n;
                }
            }
        }
        let det = smm * snn - smn * smn;
        let (a, b) = if det.abs() > 1e-9 {
            let mut a2 = [0.0; 2];
            let mut b2 = [0.0; 2];
            for c in 0..2 {
                a2[c] = (skm[c] * snn - skn[c] * smn) / det;
                b2[c] = (skn[c] * smm - skm[c] * smn) / det;
            }
            (a2, b2)
        } else {
            (a, b)
        };
        // Report the shortest real-space basis (Gauss-reduced, acute angle between).
        let (a1, a2) = dual(a, b);
        let (a1, mut a2) = reduce(a1, a2);
        if dot(a1, a2) < 0.0 {
            a2 = [-a2[0], -a2[1]];
        }
        let (a, b) = dual(a1, a2);
        let mut explained = 0;
        let mut ss = 0.0;
        for (p, k) in peaks.iter_mut().zip(&ks) {
            p.lattice_index = indices(*k, a, b);
            if let Some([m, n]) = p.lattice_index {
                explained += 1;
                let d = [k[0] - m as f64 * a[0] - n as f64 * b[0], k[1] - m as f64 * a[1] - n as f64 * b[1]];
                ss += dot(d, d);
            }
        }
        let between = (dot(a1, a2) / (dot(a1, a1) * dot(a2, a2)).sqrt()).clamp(-1.0, 1.0).acos().to_degrees();
        Some(Lattice {
            reciprocal: vec![a, b],
            basis: vec![a1, a2],
            periods: vec![dot(a1, a1).sqrt(), dot(a2, a2).sqrt()],
            angles_deg: vec![angle_deg(a1), angle_deg(a2)],
            angle_between_deg: Some(between),
            explained,
            rms_residual: (ss / explained.max(1) as f64).sqrt(),
        })
    } else {
        let (_, a) = best1?;
        let mut explained = 0;
        let mut num = 0.0;
        let mut den = 0.0;
        for k in &ks {
            if let Some(m) = index1(*k, a) {
                num += dot(*k, a) / dot(a, a) * m as f64;
                den += (m * m) as f64;
            }
        }
        let scale = if den > 0.0 { num / den } else { 1.0 };
        let a = [a[0] * scale, a[1] * scale];
        let mut ss = 0.0;
        for (p, k) in peaks.iter_mut().zip(&ks) {
            p.lattice_index = index1(*k, a).map(|m| [m, 0]);
            if let Some([m, _]) = p.lattice_index {
                explained += 1;
                let d = [k[0] - m as f64 * a[0], k[1] - m as f64 * a[1]];
                ss += dot(d, d);
            }
        }
        let aa = dot(a, a);
        let a1 = [a[0] / aa, a[1] / aa];
        Some(Lattice {
            reciprocal: vec![a],
            basis: vec![a1],
            periods: vec![1.0 / aa.sqrt()],
            angles_deg: vec![angle_deg(a1)],
            angle_between_deg: None,
            explained,
            rms_residual: (ss / explained.max(1) as f64).sqrt(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peak(kx: f64, ky: f64, w: f64) -> Peak {
        Peak {
            kx,
            ky,
            u: 0.0,
            v: 0.0,
            period: 1.0 / kx.hypot(ky),
            angle_deg: angle_deg([kx, ky]),
            strength: 100.0,
            variance_fraction: w,
            notch_sigma: 1.5,
            pass: 0,
            lattice_index: None,
        }
    }

    #[test]
    fn fits_oblique_lattice_from_its_harmonics() {
        // Real-space basis: 5 mm along 20°, 8 mm along 120° (reduced: |a1·a2| < |a1|²/2).
        let t1 = 20f64.to_radians();
        let t2 = 120f64.to_radians();
        let a1 = [5e-3 * t1.cos(), 5e-3 * t1.sin()];
        let a2 = [8e-3 * t2.cos(), 8e-3 * t2.sin()];
        let det = cross(a1, a2);
        let b1 = [a2[1] / det, -a2[0] / det];
        let b2 = [-a1[1] / det, a1[0] / det];
        let mut peaks = Vec::new();
        for m in -2i32..=2 {
            for n in -2i32..=2 {
                let k = [m as f64 * b1[0] + n as f64 * b2[0], m as f64 * b1[1] + n as f64 * b2[1]];
                // keep the half plane
                if k[1] > 0.0 || (k[1] == 0.0 && k[0] > 0.0) {
                    peaks.push(peak(k[0] + 0.3, k[1] - 0.2, 1.0 / (1 + m.abs() + n.abs()) as f64));
                }
            }
        }
        let lat = fit_lattice(&mut peaks, 8).unwrap();
        assert_eq!(lat.explained, peaks.len());
        let mut periods = lat.periods.clone();
        periods.sort_by(|a, b| a.total_cmp(b));
        // Reported with the acute angle between: 180° − 100° = 80°.
        assert!((periods[0] - 5e-3).abs() < 5e-5 && (periods[1] - 8e-3).abs() < 5e-5, "{periods:?}");
        assert!((lat.angle_between_deg.unwrap() - 80.0).abs() < 1.0, "{lat:?}");
    }

    #[test]
    fn fits_stripes_with_one_vector() {
        let mut peaks = vec![peak(100.0, 0.0, 1.0), peak(200.0, 0.0, 0.3), peak(300.0, 0.0, 0.1)];
        let lat = fit_lattice(&mut peaks, 8).unwrap();
        assert_eq!(lat.reciprocal.len(), 1);
        assert!((lat.periods[0] - 0.01).abs() < 1e-6);
        assert_eq!(peaks[2].lattice_index, Some([3, 0]));
    }

    #[test]
    fn search_space_counts_half_plane_outside_the_dc_disc() {
        for (h, w, dc) in [(8usize, 10usize, 2.0), (7, 9, 3.0), (16, 5, 1.5), (617, 871, 4.0)] {
            let mut m = 0;
            for q in 0..h {
                for r in 0..w {
                    if in_half_plane(q, r, h, w) && bin_radius(q, r, h, w) > dc {
                        m += 1;
                    }
                }
            }
            assert_eq!(search_space(h, w, dc, 1, 1e-3).bins, m, "{h}×{w}");
        }
    }

    #[test]
    fn sub_bin_offset_of_a_pure_tone() {
        // Rectangular-window DFT of a tone at offset 0.3: |D(k)| = |sin(π δ)/(π (k − δ))|·N.
        let d: f64 = 0.3;
        let mag = |k: f64| ((std::f64::consts::PI * d).sin() / (std::f64::consts::PI * (k - d))).abs();
        let est = sub_bin_offset(mag(-1.0), mag(0.0), mag(1.0));
        assert!((est - d).abs() < 1e-9, "{est}");
    }
}
