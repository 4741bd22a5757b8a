//! Gridding a web laid by the physics (`laid_web`): the same window, deposit, zone
//! curve and formation number as a stochastic web, on the stored laid fibres.
//!
//! **Window.** The laid web is periodic in CD (period n_wΔw, folded by the deposit)
//! and runs in MD from the touchdown to the start-up; its stage reports an interior MD
//! range free of both for every replicate. The window is centred in the MD range common
//! to the replicates gridded (plus `window_offset_md`) and at `window_offset_cd` in CD.
//! With `edge_margin_spreads` > 0 it must lie inside that interior (the margin itself is
//! the laid_web stage's `edge_margin_spreads`); with 0 only inside the laid extent. Its
//! side may not exceed the CD period (the window would see a fibre twice).
//!
//! **Mass.** Every laid node but a fibre's last deposits ρA·Δs (the rod's element mass;
//! `point_mass`), or its chord by `segment_clipping`.
use super::{grid_statistics, Boundary, DensityGrid, GridError, GridParams, GridResult, Period, Spreads};
use crate::stages::{BadInput, Input};
use anyhow::{bail, Result};
use ndarray::{Array1, Array2, Array4, Axis};
use rayon::prelude::*;

/// One point of a laid web, read back from its version.
#[derive(Debug, Clone)]
pub struct LaidPoint {
    /// Per replicate, per fibre: the laid nodes (x, y) in belt coordinates.
    pub fibres: Vec<Vec<Vec<[f64; 2]>>>,
    /// Per replicate: the interior MD range [min, max] (m) and the spread (m).
    pub interior: Vec<[f64; 2]>,
    pub spread: Vec<f64>,
    pub cd_period: f64,
    pub element_length: f64,
    pub mass_per_length: f64,
    /// ρA/(Δw·c) (kg/m²).
    pub expected_interior_density: f64,
}

/// Every point of a laid_web version.
pub fn read_laid_web(input: &Input) -> Result<Vec<LaidPoint>> {
    let laid: Array4<f64> = input.read_f64("laid_positions")?.into_dimensionality()?;
    let start = input.read_i64("fibre_node_start")?;
    let count = input.read_i64("fibre_laid_nodes")?;
    let md_min: Array2<f64> = input.read_f64("interior_md_min")?.into_dimensionality()?;
    let md_max: Array2<f64> = input.read_f64("interior_md_max")?.into_dimensionality()?;
    let spread: Array2<f64> = input.read_f64("spread")?.into_dimensionality()?;
    let per_point = |name: &str| -> Result<Array1<f64>> { Ok(input.read_f64(name)?.into_dimensionality()?) };
    let (period, ds, mpl, expected) = (per_point("cd_period")?, per_point("element_length")?, per_point("mass_per_length")?, per_point("expected_interior_density")?);
    let (np, reps) = (laid.shape()[0], laid.shape()[1]);
    let nf = start.shape()[2];
    let mut points = Vec::with_capacity(np);
    for p in 0..np {
        let mut fibres = Vec::with_capacity(reps);
        for r in 0..reps {
            let nodes = laid.index_axis(Axis(0), p);
            let nodes = nodes.index_axis(Axis(0), r);
            let web: Vec<Vec<[f64; 2]>> = (0..nf)
                .filter(|&j| start[[p, r, j]] >= 0)
                .map(|j| {
                    let a = start[[p, r, j]] as usize;
                    (a..a + count[[p, r, j]] as usize).map(|k| [nodes[[k, 0]], nodes[[k, 1]]]).collect()
                })
                .collect();
            fibres.push(web);
        }
        points.push(LaidPoint {
            fibres,
            interior: (0..reps).map(|r| [md_min[[p, r]], md_max[[p, r]]]).collect(),
            spread: (0..reps).map(|r| spread[[p, r]]).collect(),
            cd_period: period[p],
            element_length: ds[p],
            mass_per_length: mpl[p],
            expected_interior_density: expected[p] * 1e-3,
        });
    }
    Ok(points)
}

impl LaidPoint {
    /// Lower window corner for the first `replicates` replicates (see the module docs).
    pub fn window_corner(&self, params: &GridParams, replicates: usize) -> Result<(f64, f64)> {
        params.validate()?;
        if replicates > self.interior.len() {
            bail!(BadInput(format!("the grid asks for {replicates} realisations but the laid web has {} replicates", self.interior.len())));
        }
        if params.boundary == Boundary::Periodic {
            bail!(BadInput("boundary: periodic does not apply to a laid web (CD is periodic already, MD is as laid); use open".into()));
        }
        let h = params.window_side;
        if h > self.cd_period * (1.0 + 1e-12) {
            bail!(BadInput(format!("window_side {h} m exceeds the laid web's CD period n_w·Δw = {} m: raise fibres_across or lower window_side", self.cd_period)));
        }
        let lo = self.interior[..replicates].iter().map(|i| i[0]).fold(f64::NEG_INFINITY, f64::max);
        let hi = self.interior[..replicates].iter().map(|i| i[1]).fold(f64::INFINITY, f64::min);
        let centre = 0.5 * (lo + hi) + params.window_offset_md;
        if params.edge_margin_spreads > 0.0 && (centre - 0.5 * h < lo || centre + 0.5 * h > hi) {
            bail!(BadInput(format!(
                "window {h} m centred at MD {centre:.4} m does not fit the laid web's interior {lo:.4}..{hi:.4} m (free of the touchdown and the start-up): raise belt_travel by at least {:.4} m, or lower window_side",
                (h - (hi - lo)).max(0.0) + 2.0 * params.window_offset_md.abs()
            )));
        }
        Ok((centre - 0.5 * h, params.window_offset_cd - 0.5 * h))
    }

    /// Grid replicate `replicate` of the laid web.
    pub fn grid(&self, params: &GridParams, replicate: usize, corner: (f64, f64)) -> Result<GridResult, GridError> {
        let cells = params.validate()?;
        let fibres = &self.fibres[replicate];
        let md_extent = fibres.iter().flatten().fold([f64::INFINITY, f64::NEG_INFINITY], |a, p| [a[0].min(p[0]), a[1].max(p[0])]);
        let origin_md = md_extent[0].min(corner.0) - 1.0;
        let span_md = md_extent[1].max(corner.0 + params.window_side) - origin_md + 1.0;
        let grid = DensityGrid::try_new(corner.0, corner.1, params.cell_size, cells)?.with_period(Period {
            origin: [origin_md, corner.1],
            period: [span_md, self.cd_period],
        });
        fibres.par_iter().for_each(|nodes| grid.deposit_fibre(nodes, params.deposit));
        let stats = grid_statistics(&grid, self.mass_per_length * self.element_length, self.mass_per_length, params);
        let spread = self.spread[replicate];
        Ok(GridResult {
            expected_interior_density: self.expected_interior_density,
            window_corner: [corner.0, corner.1],
            spreads: Spreads { cross_direction: spread, machine_direction: spread },
            nodes_generated: fibres.iter().map(|f| f.len() as u64).sum(),
            ..stats
        })
    }
}
