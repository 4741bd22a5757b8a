//! The analysis of one image ([`analyze`], [`analyze_file`]): background, spectrum,
//! bond-lattice peaks, notch filter and the corrected CVs, with its result
//! [`ImageAnalysis`].

use std::path::Path;

use ndarray::Array2;

use super::*;
use crate::uniformity::{coefficient_of_variation, log_zone_sizes, ZoneCv};

/// Everything the analysis of one image produces.
#[derive(Debug, Clone)]
pub struct ImageAnalysis {
    /// Pixel size used (m).
    pub pixel_size: f64,
    /// Input grey levels, (rows, cols).
    pub raw: Array2<f64>,
    /// Image after notching the bond peaks (same mean as `raw`).
    pub filtered: Array2<f64>,
    /// log10 of the energy spectrum |F|²/N² of the analysed (periodic) component before
    /// notching, fftshifted (DC at row ⌊H/2⌋, column ⌊W/2⌋). Σ of the energy over non-DC
    /// bins is the variance. Floored at 1e-16 of the total energy.
    pub log_spectrum_raw: Array2<f64>,
    /// Same after notching.
    pub log_spectrum_notched: Array2<f64>,
    /// Detected peaks (half plane; each was notched with its conjugate), strongest first per pass.
    pub peaks: Vec<Peak>,
    /// Lattice fitted to the peaks, if any.
    pub lattice: Option<Lattice>,
    /// Number of Gaussian notches applied (2 per peak, conjugates included).
    pub notch_count: usize,
    /// Mean grey level (same before and after filtering).
    pub mean: f64,
    /// CV of the raw grey levels.
    pub cv_raw: f64,
    /// The reported uniformity, chosen by [`CV_CORR_RULE`]: `cv_corr_compensated`.
    pub cv_corr: f64,
    /// CV of the filtered image, mean kept: the paper's CV_corr. Biased low by the web
    /// variance the notches also remove (see `cv_corr_compensated`).
    pub cv_corr_plain: f64,
    /// Best estimate of the web's own CV for a zero-mean bond pattern:
    /// `√(Var(filtered) + web_variance_notched + censored_variance) / mean`, over the
    /// interior of the filtered image, which for an image with saturated pixels is the
    /// one with them restored ([`censor`]; its mean then includes the clipped excess).
    pub cv_corr_compensated: f64,
    /// Expected web variance removed with the bond peaks, `Σ (1 − g²)·B / N²` over the
    /// notch gains `g` and the background model `B` (0 without notches).
    pub web_variance_notched: f64,
    /// Estimated mean grey level added by the bonds if they are one-sided (see module docs).
    pub bond_mean_estimate: f64,
    /// Compensated CV about `mean − bond_mean_estimate` (one-sided bonds):
    /// `√(Var(filtered) + web_variance_notched) / (mean − bond_mean_estimate)`;
    /// None when that mean is not positive.
    pub cv_corr_one_sided: Option<f64>,
    /// 1 − Var(filtered)/Var(raw), whole images.
    pub fraction_variance_removed: f64,
    /// Width (pixels) of the edge band left out of the filtered-image statistics
    /// (`cv_corr*`, `zone_cv_filtered`, `bond_mean_estimate`): `edge_margin_periods`
    /// times the longest lattice period, at most a quarter of each side; 0 without lattice.
    pub margin_px: usize,
    /// Bins added to the notches by the hysteresis growth over the leakage ridges
    /// ([`grow`]; conjugates counted; 0 without peaks or with `notch_growth` off).
    pub grown_bins: usize,
    /// Fraction of the pixels at 0 or 1 that the censoring correction restored
    /// ([`censor`]; 0 when it did not run: no lattice, no saturated pixel, or off).
    pub censored_fraction: f64,
    /// Web variance the restored pixels cannot show (their mean conditional variance
    /// over the interior), added to `cv_corr_compensated` (0 without correction).
    pub censored_variance: f64,
    /// Whitened-power threshold used.
    pub threshold: f64,
    /// Bins searched per pass (M).
    pub bins_searched: usize,
    /// CV over zone sizes, raw and filtered ([`zone_curve`]: the sides actually used, each once).
    pub zone_cv_raw: Vec<ZoneCv>,
    pub zone_cv_filtered: Vec<ZoneCv>,
    /// Things the user should know (saturation, peak cap reached, constant image, ...).
    pub warnings: Vec<String>,
}

impl ImageAnalysis {
    /// The scalar results, for tables and group statistics.
    pub fn summary(&self) -> Summary {
        Summary {
            cv_raw: self.cv_raw,
            cv_corr: self.cv_corr,
            cv_corr_plain: self.cv_corr_plain,
            cv_corr_compensated: self.cv_corr_compensated,
            cv_corr_one_sided: self.cv_corr_one_sided,
            fraction_variance_removed: self.fraction_variance_removed,
            notch_count: self.notch_count,
            peak_count: self.peaks.len(),
            mean: self.mean,
            lattice_periods: self.lattice.as_ref().map(|l| l.periods.clone()).unwrap_or_default(),
        }
    }
}

/// Scalar results of one image.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Summary {
    pub cv_raw: f64,
    pub cv_corr: f64,
    pub cv_corr_plain: f64,
    pub cv_corr_compensated: f64,
    pub cv_corr_one_sided: Option<f64>,
    pub fraction_variance_removed: f64,
    pub notch_count: usize,
    pub peak_count: usize,
    pub mean: f64,
    /// Detected bond repeat distances (m), empty without a lattice.
    pub lattice_periods: Vec<f64>,
}

fn mean_var(a: &Array2<f64>) -> (f64, f64) {
    let n = a.len() as f64;
    let m = a.sum() / n;
    let v = a.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n;
    (m, v)
}

/// fftshifted log10 energy spectra before and after notching, floored at 1e-16 of the
/// total energy. The notched one reuses the first where the gain is 1.
fn log_energies(power: &Array2<f64>, gain: &Array2<f64>, n2: f64) -> (Array2<f64>, Array2<f64>) {
    use rayon::prelude::*;
    let (h, w) = power.dim();
    let total: f64 = power.sum() / n2;
    let floor = (total * 1e-16).max(f64::MIN_POSITIVE);
    let lf = floor.log10();
    let mut before = Array2::<f64>::zeros((h, w));
    let mut after = Array2::<f64>::zeros((h, w));
    let (p, g) = (power.as_slice().unwrap(), gain.as_slice().unwrap());
    // Row i of the shifted arrays holds spectrum row (i + h − h/2) % h, columns likewise.
    before
        .as_slice_mut()
        .unwrap()
        .par_chunks_mut(w)
        .zip(after.as_slice_mut().unwrap().par_chunks_mut(w))
        .enumerate()
        .for_each(|(i, (b, a))| {
            let q = (i + h - h / 2) % h;
            for j in 0..w {
                let r = (j + w - w / 2) % w;
                let e = p[q * w + r] / n2;
                // ln·log10(e) is markedly faster than log10 in glibc.
                let lb = e.max(floor).ln() * std::f64::consts::LOG10_E;
                b[j] = lb;
                let gg = g[q * w + r];
                a[j] = if gg == 1.0 { lb } else { ((e * gg * gg).max(floor).ln() * std::f64::consts::LOG10_E).max(lf) };
            }
        });
    (before, after)
}

/// The image whose spectrum is `spectrum` with the notch gains applied.
fn notch_filtered(plan: &fft2::Fft2, mut spectrum: Array2<num_complex::Complex64>, gain: &Array2<f64>) -> Array2<f64> {
    spectrum.zip_mut_with(gain, |f, g| *f *= *g);
    plan.inverse_real(&spectrum)
}

/// A cached FFT plan per image shape (planning prime sizes such as 617 costs milliseconds).
fn plan_for(h: usize, w: usize) -> std::sync::Arc<fft2::Fft2> {
    use std::collections::HashMap;
    use std::sync::{Arc, Mutex, OnceLock};
    type Plans = HashMap<(usize, usize), Arc<fft2::Fft2>>;
    static PLANS: OnceLock<Mutex<Plans>> = OnceLock::new();
    let mut m = PLANS.get_or_init(|| Mutex::new(HashMap::new())).lock().unwrap_or_else(|e| e.into_inner());
    if m.len() > 16 {
        m.clear();
    }
    m.entry((h, w)).or_insert_with(|| Arc::new(fft2::Fft2::new(h, w))).clone()
}

/// Analyses one grey image (any positive scale, e.g. [0, 1]) of pixel size `pixel_size` (m).
///
/// Errors: invalid parameters, images smaller than [`MIN_SIDE`], non-finite values, a
/// non-positive mean. A constant image is not an error: CV 0, no peaks, and a warning.
pub fn analyze(image: &Array2<f64>, pixel_size: f64, params: &ImageParams) -> Result<ImageAnalysis, ImageError> {
    params.validate()?;
    if !(pixel_size > 0.0 && pixel_size.is_finite()) {
        return Err(ImageError::InvalidParam {
            name: "pixel_size",
            value: pixel_size.to_string(),
            allowed: "a positive length in metres".into(),
        });
    }
    let (h, w) = image.dim();
    if h < MIN_SIDE || w < MIN_SIDE {
        return Err(ImageError::TooSmall { path: None, rows: h, cols: w, min: MIN_SIDE });
    }
    let bad = image.iter().filter(|v| !v.is_finite()).count();
    if bad > 0 {
        return Err(ImageError::NonFinite { path: None, count: bad });
    }
    let raw = image.to_owned();
    let (mean, var_raw) = mean_var(&raw);
    if !(mean > 0.0) {
        return Err(ImageError::NonPositiveMean { path: None, mean });
    }
    let mut warnings = Vec::new();
    let (lo, hi) = raw.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if hi <= 1.0 && lo >= 0.0 {
        let sat = raw.iter().filter(|&&v| v <= 0.0 || v >= 1.0).count() as f64 / raw.len() as f64;
        if sat > 0.01 {
            warnings.push(format!(
                "{:.1} % of pixels are saturated at 0 or 1: the web under clipped pixels is censored and clipped bonds are not purely periodic; cv_corr restores the clipped web from the lattice (censoring correction), cv_corr_plain (the paper's) does not and is biased (low when bonds clip to white)",
                100.0 * sat
            ));
        }
    }
    let n = (h * w) as f64;
    let n2 = n * n;
    let cell = pixel_size;
    let zones = log_zone_sizes(params.zone_min, params.zone_max, params.zones_per_octave);
    let cv_raw = coefficient_of_variation(raw.iter().copied());


    let plan = plan_for(h, w);
    let (p_hat, u_hat) = if params.periodic_decomposition {
        periodic::periodic_and_image_spectra(&raw, &plan)
    } else {
        let u = plan.forward_real(&raw);
        (u.clone(), u)
    };
    let power = p_hat.mapv(|z| z.norm_sqr());
    let total_ac = power.sum() - power[[0, 0]];
    let space = peaks::search_space(h, w, params.dc_exclusion_bins, params.max_passes, params.false_alarm_rate);
    let mut mask = notch::NotchMask::new(h, w);
    let mut found: Vec<Peak> = Vec::new();
    let mut web_var_notched = 0.0;
    let mut growth = grow::Growth::default();

    let constant = lo == hi;
    if constant || !(total_ac > 0.0) {
        if constant {
            warnings.push("constant image: CV is 0 and there is nothing to filter".into());
        }
    } else {
        let bg = background::fit(&power, params.background_sectors, params.background_smoothing, params.background_pool);
        // Per-bin threshold, interpolated from a table over the background's log error.
        let thr = background::corrected_thresholds(space.threshold, &bg.log_sd);
        let mut seeds: Vec<(usize, usize)> = Vec::new();
        let mut taken = Array2::from_elem((h, w), false);
        for pass in 0..params.max_passes {
            let cands = peaks::find_candidates(
                &power,
                &mask.gain,
                &bg.mean_power,
                total_ac,
                space.threshold,
                &thr,
                params.dc_exclusion_bins,
                params.min_peak_fraction,
                &taken,
            );
            if cands.is_empty() {
                break;
            }
            let room = params.max_peaks.saturating_sub(found.len());
            // Positions are refined on this pass's input, before its own notches.
            let refined: Vec<(f64, f64)> = cands.iter().take(room).map(|c| peaks::refine(&p_hat, &mask.gain, c.q, c.r)).collect();
            for (c, &(v, u)) in cands.iter().zip(&refined) {
                let off = (v - v.round()).abs().max((u - u.round()).abs());
                let sigma = params.notch_sigma_bins * (1.0 + params.off_grid_widening * 2.0 * off);
                mask.add_pair(v, u, sigma);
                taken[[c.q, c.r]] = true;
                seeds.push((c.q, c.r));
                let kx = u / (w as f64 * cell);
                let ky = v / (h as f64 * cell);
                let kk = kx.hypot(ky);
                found.push(Peak {
                    kx,
                    ky,
                    u,
                    v,
                    period: 1.0 / kk,
                    angle_deg: ky.atan2(kx).to_degrees().rem_euclid(180.0),
                    strength: c.w,
                    variance_fraction: 2.0 * (c.power - c.bg) / total_ac,
                    notch_sigma: sigma,
                    pass,
                    lattice_index: None,
                });
            }
            if cands.len() > room {
                warnings.push(format!("peak limit max_peaks = {} reached; stronger peaks were kept", params.max_peaks));
                break;
            }
        }
        // The DC bin is never attenuated: notching keeps the image mean (a notch close
        // to DC would otherwise scale the mean and bias every CV).
        drop(thr);
        mask.keep_dc();
        let mut bg = bg;
        if !found.is_empty() && params.notch_growth {
            // Hysteresis growth over the leakage ridges ([`grow`]).
            let (region, g) = grow::grow(&power, &bg.mean_power, &bg.log_sd, &seeds, params.false_alarm_rate, params.dc_exclusion_bins);
            growth = g;
            mask.gain.zip_mut_with(&region, |g, &inside| {
                if inside {
                    *g = 0.0;
                }
            });
            mask.keep_dc();
            // The background refitted without the bond's power: the grown bins and any bin
            // above `ln(pool)` times the model (one web bin per pool is expected there),
            // which peak cores and the ridges' tails below the growth threshold are. The
            // ridges inflate the pools' medians, i.e. the web power the compensation adds
            // back. Bins are left out by their power, not by the notches' extent: a wide
            // notch would take whole cells out and leave their pools to bins farther out
            // on the steep central peak (σ = 6 bins: −1.9 % on a 150 px image).
            let t_clip = (params.background_pool as f64).ln();
            let exclude = Array2::from_shape_fn((h, w), |(q, r)| region[[q, r]] || power[[q, r]] > t_clip * bg.mean_power[[q, r]]);
            bg = background::fit_excluding(&power, params.background_sectors, params.background_smoothing, params.background_pool, Some(&exclude));
        }
        if !found.is_empty() {
            // Expected web variance inside the notches: Σ (1 − g²) E|F|² / N², DC excluded.
            web_var_notched = mask
                .gain
                .iter()
                .zip(bg.mean_power.iter())
                .skip(1)
                .map(|(g, b)| (1.0 - g * g) * b)
                .sum::<f64>()
                / n2;
        }
    }

    let filtered = if found.is_empty() {
        // Nothing notched: the image is returned bit for bit (no FFT round-off).
        raw.clone()
    } else {
        // The notches act on the whole image spectrum (periodic + smooth parts), as in
        // the paper; the decomposition only keeps edge artefacts out of the detection.
        notch_filtered(&plan, u_hat, &mask.gain)
    };
    // Statistics of the filtered image over the interior: a band of `edge_margin_periods`
    // bond periods along the edges keeps residual bond pattern (the notches cannot remove
    // the part of an off-grid harmonic that wraps around the image edges).
    let lattice = peaks::fit_lattice(&mut found, 8);
    let margin_px = match &lattice {
        Some(l) if params.edge_margin_periods > 0.0 => {
            let p = l.periods.iter().copied().fold(0.0, f64::max);
            ((params.edge_margin_periods * p / cell).round() as usize).min(h / 4).min(w / 4)
        }
        _ => 0,
    };
    let interior = |a: &Array2<f64>| a.slice(ndarray::s![margin_px..h - margin_px, margin_px..w - margin_px]).to_owned();
    let filtered_in = interior(&filtered);
    let (mean_in, var_f) = if found.is_empty() { (mean, var_raw) } else { mean_var(&filtered_in) };
    let cv_corr_plain = if found.is_empty() { cv_raw } else { var_f.sqrt() / mean_in };
    // Saturated pixels ([`censor`]): the compensated statistics use the image with the
    // clipped web restored from the lattice, filtered by the same notches.
    let censoring = match (&lattice, found.is_empty() || !params.censoring_correction) {
        (Some(l), false) => censor::censored(&raw).map(|c| censor::correct(&raw, &c, &filtered, cell, l, margin_px)),
        _ => None,
    };
    let (stat_raw_in, stat_filtered_in, var_censored) = match &censoring {
        Some(c) => {
            let f = notch_filtered(&plan, plan.forward_real(&c.imputed), &mask.gain);
            (interior(&c.imputed), interior(&f), interior(&c.conditional_variance).mean().unwrap_or(0.0))
        }
        None => (interior(&raw), filtered_in.clone(), 0.0),
    };
    let (mean_c, var_fc) = if censoring.is_some() { mean_var(&stat_filtered_in) } else { (mean_in, var_f) };
    let var_comp = var_fc + web_var_notched + var_censored;
    let cv_corr_compensated = if found.is_empty() { cv_raw } else { var_comp.sqrt() / mean_c };
    let fraction_variance_removed = if var_raw > 0.0 { 1.0 - mean_var(&filtered).1 / var_raw } else { 0.0 };
    // One-sided bond mean: median level of the removed (zero-mean) pattern.
    let (bond_mean_estimate, cv_corr_one_sided) = if found.is_empty() {
        (0.0, Some(cv_corr_plain))
    } else {
        // A third of the pixels is plenty for a median.
        let mut removed: Vec<f64> = stat_raw_in.iter().zip(stat_filtered_in.iter()).step_by(3).map(|(a, b)| a - b).collect();
        let k = removed.len() / 2;
        let (_, med, _) = removed.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        let est = -*med;
        let m = mean_c - est;
        (est, if m > 0.0 { Some(var_comp.sqrt() / m) } else { None })
    };
    if let Some(c) = &censoring {
        if c.unresolved_phases > 0 {
            warnings.push(format!(
                "{} of {} lattice phases are saturated in all their pixels: the level of the bond pattern there is only bounded, so the web restored under them (and cv_corr) is uncertain",
                c.unresolved_phases, c.phases
            ));
        }
    }
    if !found.is_empty() && lattice.is_none() {
        warnings.push("peaks were found but no lattice fits them".into());
    }
    let ((zone_cv_raw, zone_cv_filtered), (log_spectrum_raw, log_spectrum_notched)) = rayon::join(
        || rayon::join(|| zone_curve(&raw, cell, &zones, Some(cv_raw)), || zone_curve(&filtered_in, cell, &zones, None)),
        || log_energies(&power, &mask.gain, n2),
    );
    Ok(ImageAnalysis {
        pixel_size,
        log_spectrum_raw,
        log_spectrum_notched,
        raw,
        filtered,
        notch_count: mask.count,
        peaks: found,
        lattice,
        mean,
        cv_raw,
        // CV_CORR_RULE.
        cv_corr: cv_corr_compensated,
        cv_corr_plain,
        cv_corr_compensated,
        web_variance_notched: web_var_notched,
        bond_mean_estimate,
        cv_corr_one_sided,
        fraction_variance_removed,
        margin_px,
        grown_bins: growth.bins,
        censored_fraction: censoring.as_ref().map_or(0.0, |c| c.fraction),
        censored_variance: var_censored,
        threshold: space.threshold,
        bins_searched: space.bins,
        zone_cv_raw,
        zone_cv_filtered,
        warnings,
    })
}

/// Reads and analyses one file, with the pixel size of [`ImageParams::pixel_size_for`].
pub fn analyze_file(path: &Path, params: &ImageParams) -> Result<ImageAnalysis, ImageError> {
    let img = read_grey(path)?;
    let (pixel, _) = params.pixel_size_for(&img)?;
    analyze(&img.data, pixel, params).map_err(|e| e.with_path(path))
}
