//! The CV against zone size of a map ([`zone_curve`]), from one summed-area table.

use ndarray::Array2;

use crate::uniformity::{coefficient_of_variation, ZoneCv};

/// Same result as [`crate::uniformity::cv_by_zone_size`] (same zone rounding and skip
/// rules, CV by [`coefficient_of_variation`]) up to rounding, much faster on scan-sized
/// images: block sums come from one summed-area table of the mean-removed map (which
/// keeps the table small, so differences of its entries lose no precision). `cv_k1`, if
/// known, is used for 1-pixel zones.
///
/// Unlike `cv_by_zone_size`, each [`ZoneCv::zone_size`] is the side actually used,
/// `cells_per_side × cell`, not the requested one: requested sizes that round to the
/// same whole number of pixels give one entry, so the curve has no repeated or
/// mislabelled sizes (at 1 mm pixels, 0.5, 0.71, 1 and 1.41 mm are all the 1 mm zone).
pub fn zone_curve(map: &Array2<f64>, cell: f64, zone_sizes: &[f64], cv_k1: Option<f64>) -> Vec<ZoneCv> {
    let (h, w) = map.dim();
    let mean = map.sum() / (h * w).max(1) as f64;
    let mut sat: Option<Vec<f64>> = None;
    let mut out: Vec<ZoneCv> = Vec::new();
    let mut blocks: Vec<f64> = Vec::new();
    for &zone_size in zone_sizes {
        let k = (zone_size / cell).round() as usize;
        if k == 0 || out.iter().any(|z| z.cells_per_side == k) {
            continue;
        }
        let (rows, cols) = (h / k, w / k);
        if rows * cols < 4 {
            continue;
        }
        if k == 1 {
            let cv = cv_k1.unwrap_or_else(|| coefficient_of_variation(map.iter().copied()));
            out.push(ZoneCv { zone_size: cell, cells_per_side: 1, zones: h * w, cv });
            continue;
        }
        let s = sat.get_or_insert_with(|| {
            let w1 = w + 1;
            let mut s = vec![0.0; (h + 1) * w1];
            for i in 0..h {
                let mut run = 0.0;
                for j in 0..w {
                    run += map[[i, j]] - mean;
                    s[(i + 1) * w1 + j + 1] = s[i * w1 + j + 1] + run;
                }
            }
            s
        });
        let w1 = w + 1;
        let base = (k * k) as f64 * mean;
        blocks.clear();
        for bi in 0..rows {
            let (i0, i1) = (bi * k, bi * k + k);
            for bj in 0..cols {
                let (j0, j1) = (bj * k, bj * k + k);
                blocks.push(s[i1 * w1 + j1] - s[i0 * w1 + j1] - s[i1 * w1 + j0] + s[i0 * w1 + j0] + base);
            }
        }
        out.push(ZoneCv { zone_size: k as f64 * cell, cells_per_side: k, zones: rows * cols, cv: coefficient_of_variation(blocks.iter().copied()) });
    }
    out
}
