//! Rendering areal-density maps as transmission images, with an optional periodic bond
//! pattern, so the image method can be run on webs whose true uniformity is known; and
//! two small synthetic-web generators for tests and examples (they are **not** the
//! paper's web model, which is the `web` stage).
//!
//! # Rendering model
//! Each density cell becomes one pixel (pixel size = cell size). Grey level from the
//! Beer–Lambert transmission of the local areal density ρ (g/m²):
//!
//! `grey = black + (white − black) · exp(−k ρ) + bond(x)`, then clipped to [0, 1] and,
//! if `bits > 0`, quantised to `2^bits − 1` levels.
//!
//! `k` (m²/g) is the mass attenuation; with the default 0.02 m²/g a 40 g/m² web passes
//! 45 % of the light. The bond pattern is additive in grey level: `bond(x) = contrast ·
//! c(x)` where `c` is the area fraction of the pixel covered by bond shapes (computed by
//! `supersample²` point samples), positive `contrast` making bonds brighter (fused film
//! is more transparent). With `zero_mean` the image mean of `contrast·c` is subtracted,
//! so the pattern adds no mean grey level and the web's own CV is recovered exactly by a
//! perfect notch filter; without it the pattern raises the mean by `contrast·f` (`f` the
//! bond area fraction), which the notch filter keeps (see the stage docs).
//!
//! ```
//! use laydown::stages::image::render::{render, BondPattern, BondShape, RenderParams};
//! use ndarray::Array2;
//! let density = Array2::from_elem((64, 64), 20.0); // uniform 20 g/m²
//! let mut rp = RenderParams::default();
//! rp.bonds = Some(BondPattern {
//!     shape: BondShape::Circle { diameter: 1.0e-3 },
//!     ..BondPattern::default()
//! });
//! let img = render(&density, 0.25e-3, &rp).unwrap();
//! let bare = (-0.02f64 * 20.0).exp();
//! assert!((img.grey[[0, 0]] - bare).abs() < 1e-12 || img.grey[[0, 0]] > bare);
//! assert!(img.bond_area_fraction > 0.0 && img.bond_area_fraction < 0.2);
//! ```
use ndarray::Array2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::ImageError;

/// Shape of one bond, dimensions in metres, angles in degrees from +x towards +y.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BondShape {
    Circle { diameter: f64 },
    Ellipse { major: f64, minor: f64, angle_deg: f64 },
    Rectangle { width: f64, height: f64, angle_deg: f64 },
}

impl BondShape {
    /// Area of one bond (m²).
    pub fn area(&self) -> f64 {
        match *self {
            BondShape::Circle { diameter } => std::f64::consts::PI * diameter * diameter / 4.0,
            BondShape::Ellipse { major, minor, .. } => std::f64::consts::PI * major * minor / 4.0,
            BondShape::Rectangle { width, height, .. } => width * height,
        }
    }

    fn contains(&self, dx: f64, dy: f64) -> bool {
        match *self {
            BondShape::Circle { diameter } => dx * dx + dy * dy <= diameter * diameter / 4.0,
            BondShape::Ellipse { major, minor, angle_deg } => {
                let (s, c) = angle_deg.to_radians().sin_cos();
                let x = c * dx + s * dy;
                let y = -s * dx + c * dy;
                let (a, b) = (major / 2.0, minor / 2.0);
                (x / a).powi(2) + (y / b).powi(2) <= 1.0
            }
            BondShape::Rectangle { width, height, angle_deg } => {
                let (s, c) = angle_deg.to_radians().sin_cos();
                let x = c * dx + s * dy;
                let y = -s * dx + c * dy;
                x.abs() <= width / 2.0 && y.abs() <= height / 2.0
            }
        }
    }

    fn radius(&self) -> f64 {
        match *self {
            BondShape::Circle { diameter } => diameter / 2.0,
            BondShape::Ellipse { major, minor, .. } => major.max(minor) / 2.0,
            BondShape::Rectangle { width, height, .. } => 0.5 * width.hypot(height),
        }
    }
}

/// A periodic bond lattice: bond centres at `offset + m·a1 + n·a2`, with
/// `a1 = period1·(cos θ, sin θ)` and `a2 = period2·(cos(θ+β), sin(θ+β))`,
/// θ = `angle_deg`, β = `angle_between_deg`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct BondPattern {
    /// |a1| (m). Default 4 mm.
    pub period1: f64,
    /// |a2| (m). Default 4 mm.
    pub period2: f64,
    /// Direction of a1, degrees from +x (columns) towards +y (rows). Default 0.
    pub angle_deg: f64,
    /// Angle from a1 to a2, degrees (90 = rectangular, 60 = staggered). Default 90.
    pub angle_between_deg: f64,
    /// Position of one bond centre (m) from the top-left pixel corner. Default (0, 0).
    pub offset: [f64; 2],
    /// Bond shape. Default circle of 1 mm.
    pub shape: BondShape,
    /// Grey-level change inside a bond (fraction of full scale). Default 0.2.
    pub contrast: f64,
    /// Subtract the pattern's image mean so it adds no mean grey level. Default true.
    pub zero_mean: bool,
    /// Point samples per pixel side for the bond area fraction. Default 4.
    pub supersample: usize,
}

impl Default for BondPattern {
    fn default() -> Self {
        BondPattern {
            period1: 4e-3,
            period2: 4e-3,
            angle_deg: 0.0,
            angle_between_deg: 90.0,
            offset: [0.0, 0.0],
            shape: BondShape::Circle { diameter: 1e-3 },
            contrast: 0.2,
            zero_mean: true,
            supersample: 4,
        }
    }
}

impl BondPattern {
    /// Real-space lattice vectors (a1, a2) in metres.
    pub fn vectors(&self) -> ([f64; 2], [f64; 2]) {
        let t1 = self.angle_deg.to_radians();
        let t2 = (self.angle_deg + self.angle_between_deg).to_radians();
        ([self.period1 * t1.cos(), self.period1 * t1.sin()], [self.period2 * t2.cos(), self.period2 * t2.sin()])
    }

    /// Bond area coverage c ∈ [0, 1] of each pixel of a (rows, cols) image of pixel `pixel` m.
    pub fn coverage(&self, rows: usize, cols: usize, pixel: f64) -> Array2<f64> {
        let (a1, a2) = self.vectors();
        let det = a1[0] * a2[1] - a1[1] * a2[0];
        // Dual vectors give fractional lattice coordinates.
        let b1 = [a2[1] / det, -a2[0] / det];
        let b2 = [-a1[1] / det, a1[0] / det];
        let ss = self.supersample.max(1);
        // How many neighbouring lattice points a bond can reach into.
        let reach = (self.shape.radius() * (b1[0].hypot(b1[1]).max(b2[0].hypot(b2[1])))).ceil() as i64 + 1;
        let inv = 1.0 / (ss * ss) as f64;
        Array2::from_shape_fn((rows, cols), |(i, j)| {
            let mut hits = 0usize;
            for si in 0..ss {
                for sj in 0..ss {
                    let x = (j as f64 + (sj as f64 + 0.5) / ss as f64) * pixel - self.offset[0];
                    let y = (i as f64 + (si as f64 + 0.5) / ss as f64) * pixel - self.offset[1];
                    let fa = (b1[0] * x + b1[1] * y).round() as i64;
                    let fb = (b2[0] * x + b2[1] * y).round() as i64;
                    'search: for m in fa - reach..=fa + reach {
                        for n in fb - reach..=fb + reach {
                            let cx = m as f64 * a1[0] + n as f64 * a2[0];
                            let cy = m as f64 * a1[1] + n as f64 * a2[1];
                            if self.shape.contains(x - cx, y - cy) {
                                hits += 1;
                                break 'search;
                            }
                        }
                    }
                }
            }
            hits as f64 * inv
        })
    }
}

/// How a density map becomes grey levels.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct RenderParams {
    /// Mass attenuation k (m²/g) in T = exp(−k ρ). Default 0.02.
    pub attenuation: f64,
    /// Grey level of an empty pixel (T = 1). Default 1.
    pub white: f64,
    /// Grey level of an opaque pixel (T = 0). Default 0.
    pub black: f64,
    /// Quantisation bits (0 = keep f64, else 1..=16). Default 0.
    pub bits: u8,
    /// Optional bond lattice overlay.
    pub bonds: Option<BondPattern>,
}

impl Default for RenderParams {
    fn default() -> Self {
        RenderParams { attenuation: 0.02, white: 1.0, black: 0.0, bits: 0, bonds: None }
    }
}

/// A rendered image with what went into it.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// Final grey levels in [0, 1].
    pub grey: Array2<f64>,
    /// The additive bond term (zeros without bonds), before clipping.
    pub bond: Array2<f64>,
    /// Mean bond coverage of the image (bond area fraction f).
    pub bond_area_fraction: f64,
    /// Fraction of pixels clipped at 0 or 1.
    pub saturated_fraction: f64,
}

/// A rendering parameter outside its allowed values.
fn bad(name: &'static str, value: f64, allowed: &str) -> ImageError {
    ImageError::InvalidParam { name, value: value.to_string(), allowed: allowed.to_string() }
}

/// Renders an areal-density map (g/m², cell size `cell` m) as a transmission image.
pub fn render(density: &Array2<f64>, cell: f64, p: &RenderParams) -> Result<Rendered, ImageError> {
    render_with_coverage(density, cell, p, None)
}

/// [`render`] with the bond coverage of the lattice already computed
/// ([`BondPattern::coverage`] for this image size and `cell`): maps of one size share it,
/// and it costs more than the rest of the rendering.
pub fn render_with_coverage(density: &Array2<f64>, cell: f64, p: &RenderParams, coverage: Option<&Array2<f64>>) -> Result<Rendered, ImageError> {
    if !(cell > 0.0 && cell.is_finite()) {
        return Err(bad("cell_size", cell, "a positive length in metres"));
    }
    if !(p.attenuation >= 0.0 && p.attenuation.is_finite()) {
        return Err(bad("attenuation", p.attenuation, "k ≥ 0 (m²/g)"));
    }
    let n_bad = density.iter().filter(|v| !v.is_finite()).count();
    if n_bad > 0 {
        return Err(ImageError::NonFinite { path: None, count: n_bad });
    }
    let grey = density.mapv(|rho| p.black + (p.white - p.black) * (-p.attenuation * rho.max(0.0)).exp());
    overlay(grey, cell, p, coverage)
}

/// Adds the bond lattice of `p` (if any) to grey levels, then clips to [0, 1] and
/// quantises to `p.bits`: the part of [`render`] after the transmission, shared by
/// images that are not rendered from a density map (synthetic test images).
pub fn overlay(mut grey: Array2<f64>, pixel: f64, p: &RenderParams, coverage: Option<&Array2<f64>>) -> Result<Rendered, ImageError> {
    if p.bits > 16 {
        return Err(bad("bits", p.bits as f64, "0 (no quantisation) to 16"));
    }
    let (h, w) = grey.dim();
    let mut bond = Array2::zeros((h, w));
    let mut f = 0.0;
    if let Some(b) = &p.bonds {
        if !(b.period1 > 0.0 && b.period2 > 0.0) {
            return Err(bad("bonds.period", b.period1.min(b.period2), "positive periods (m)"));
        }
        let s = b.angle_between_deg.to_radians().sin();
        if s.abs() < 1e-3 {
            return Err(bad("bonds.angle_between_deg", b.angle_between_deg, "not a multiple of 180°"));
        }
        let computed;
        let c = match coverage {
            Some(c) if c.dim() == (h, w) => c,
            Some(c) => {
                return Err(ImageError::InvalidParam { name: "coverage", value: format!("{:?}", c.dim()), allowed: format!("the image size {h} × {w}") })
            }
            None => {
                computed = b.coverage(h, w, pixel);
                &computed
            }
        };
        f = c.mean().unwrap_or(0.0);
        let shift = if b.zero_mean { f } else { 0.0 };
        bond = c.mapv(|v| b.contrast * (v - shift));
        grey += &bond;
    }
    let mut clipped = 0usize;
    let levels = if p.bits > 0 { ((1u32 << p.bits) - 1) as f64 } else { 0.0 };
    grey.mapv_inplace(|g| {
        if !(0.0..=1.0).contains(&g) {
            clipped += 1;
        }
        let g = g.clamp(0.0, 1.0);
        if levels > 0.0 { (g * levels).round() / levels } else { g }
    });
    Ok(Rendered { grey, bond, bond_area_fraction: f, saturated_fraction: clipped as f64 / (h * w).max(1) as f64 })
}

/// Random straight fibres deposited on a periodic grid: a quick stand-in for a web with
/// known statistics (a Poisson line process, CV² ≈ E1/(π L_A x) at zone size x).
///
/// Fibres of length `fibre_length` (m) and linear density `linear_density` (g/m) are
/// placed with uniform centres; orientation is uniform, or, with `md_spread_deg = Some(s)`,
/// Gaussian with standard deviation `s` about the machine direction (+y, image rows).
/// Mass is deposited every cell/4 along each fibre into the containing cell (wrapping
/// periodically) until the mean density reaches `mean_density` (g/m²).
#[allow(clippy::too_many_arguments)]
pub fn random_fibre_web(
    rows: usize,
    cols: usize,
    cell: f64,
    mean_density: f64,
    fibre_length: f64,
    linear_density: f64,
    md_spread_deg: Option<f64>,
    seed: u64,
) -> Array2<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let area = rows as f64 * cols as f64 * cell * cell;
    let n = (mean_density * area / (linear_density * fibre_length)).round() as usize;
    let step = cell / 4.0;
    let steps = (fibre_length / step).round().max(1.0) as usize;
    let dm = linear_density * fibre_length / steps as f64 / (cell * cell);
    let mut map = Array2::<f64>::zeros((rows, cols));
    let (wm, hm) = (cols as f64 * cell, rows as f64 * cell);
    for _ in 0..n {
        let x0 = rng.random::<f64>() * wm;
        let y0 = rng.random::<f64>() * hm;
        let th = match md_spread_deg {
            None => rng.random::<f64>() * std::f64::consts::PI,
            Some(s) => {
                // Box–Muller normal about +y.
                let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
                let z = (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
                std::f64::consts::FRAC_PI_2 + z * s.to_radians()
            }
        };
        let (s, c) = th.sin_cos();
        for k in 0..steps {
            let t = (k as f64 + 0.5) * step - fibre_length / 2.0;
            let x = (x0 + t * c).rem_euclid(wm);
            let y = (y0 + t * s).rem_euclid(hm);
            let j = ((x / cell) as usize).min(cols - 1);
            let i = ((y / cell) as usize).min(rows - 1);
            map[[i, j]] += dm;
        }
    }
    map
}

/// Gaussian-smoothed white noise (periodic), scaled to the given mean and CV: a smooth,
/// noise-free "web" whose spectrum falls to round-off at high frequency.
pub fn smoothed_noise(rows: usize, cols: usize, sigma_px: f64, mean: f64, cv: f64, seed: u64) -> Array2<f64> {
    try_smoothed_noise(rows, cols, sigma_px, mean, cv, seed).unwrap_or_else(|e| panic!("{e}"))
}

/// [`smoothed_noise`] with its buffers allocated fallibly (16 B per pixel, then 8 B).
pub fn try_smoothed_noise(rows: usize, cols: usize, sigma_px: f64, mean: f64, cv: f64, seed: u64) -> Result<Array2<f64>, crate::memory::AllocError> {
    use super::fft2::{signed_index, Fft2};
    use num_complex::Complex64;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut a = crate::memory::try_array((rows, cols), Complex64::default(), "a synthetic noise image's spectrum")?;
    a.iter_mut().for_each(|z| z.re = rng.random::<f64>() - 0.5);
    let plan = Fft2::new(rows, cols);
    plan.forward(&mut a);
    let two_pi_s = 2.0 * std::f64::consts::PI * sigma_px;
    for ((q, r), z) in a.indexed_iter_mut() {
        let fy = signed_index(q, rows) as f64 / rows as f64;
        let fx = signed_index(r, cols) as f64 / cols as f64;
        *z *= (-0.5 * two_pi_s * two_pi_s * (fx * fx + fy * fy)).exp();
    }
    a[[0, 0]] = Complex64::default();
    plan.inverse(&mut a);
    let mut re = crate::memory::try_array((rows, cols), 0.0, "a synthetic noise image")?;
    re.zip_mut_with(&a, |v, z| *v = z.re);
    drop(a);
    let sd = (re.mapv(|v| v * v).mean().unwrap()).sqrt();
    re.mapv_inplace(|v| mean * (1.0 + cv * v / sd));
    Ok(re)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bond_fraction_matches_geometry_and_zero_mean_holds() {
        let b = BondPattern { period1: 5e-3, period2: 4e-3, angle_deg: 15.0, ..Default::default() };
        let rp = RenderParams { bonds: Some(b.clone()), ..Default::default() };
        let img = render(&Array2::from_elem((200, 200), 10.0), 0.2e-3, &rp).unwrap();
        let f_true = b.shape.area() / (5e-3 * 4e-3);
        assert!((img.bond_area_fraction - f_true).abs() < 0.05 * f_true, "{} vs {f_true}", img.bond_area_fraction);
        assert!(img.bond.mean().unwrap().abs() < 1e-12);
    }

    #[test]
    fn random_web_has_requested_mean_density() {
        let m = random_fibre_web(64, 64, 0.5e-3, 20.0, 10e-3, 1e-3, None, 1);
        let mean = m.mean().unwrap();
        assert!((mean - 20.0).abs() < 0.5, "{mean}");
    }

    #[test]
    fn rejects_bad_render_parameters() {
        let d = Array2::from_elem((4, 4), 1.0);
        assert!(matches!(render(&d, 0.0, &RenderParams::default()), Err(ImageError::InvalidParam { name: "cell_size", .. })));
        let mut d2 = d.clone();
        d2[[1, 1]] = f64::NAN;
        assert!(matches!(render(&d2, 1e-3, &RenderParams::default()), Err(ImageError::NonFinite { .. })));
    }
}
