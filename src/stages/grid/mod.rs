//! Grid stage numerics (§3.3 eq 16, Tables 2-3, Fig 10): areal density of a web on
//! a square window of Δh cells, its mean ρ_av and CV, CV over zone sizes and the
//! formation number against a random network of straight lines.
//!
//! **Window placement.** The window (side H) is centred by default on the web's CD
//! centre line and on the middle of the belt drift, x = c·n_l·L/2; `window_offset_md`
//! and `window_offset_cd` move it. Fibres wander sideways and along the belt (a random
//! walk in arc length), so near the web's CD edges and near the start or end of the
//! drift the density falls short of the interior value ρA/(Δw·c). The run therefore
//! measures, from the fibres it generates,
//! - σ_CD: RMS CD displacement y(s_w) − y(0) of the fibres at the arc length s_w where
//!   the nominal drift c·s reaches the window's far MD edge (or the fibre end), and
//! - σ_MD: RMS MD displacement x − c·s of the fibre ends from the nominal drift,
//!
//! and fails with [`GridError::WindowTooCloseToEdge`] unless the window keeps
//! `edge_margin_spreads` (default 3) times σ_CD from both CD edges of the starting
//! row (±n_wΔw/2) and σ_MD from x = 0 and from x = c·n_l·L. A window that does not fit
//! in the nominal web at all, c = 0 (no interior), or Δh not dividing H fail before
//! anything is generated. With [`Boundary::Periodic`] the web is folded onto a torus
//! (MD period c·n_l·L, CD period n_wΔw): no edges, no run-in, no margin check.
//!
//! ```
//! use laydown::stages::spectra::SquareWaveParams;
//! use laydown::stages::web::{Web, WebParams};
//! use laydown::stages::grid::{grid_realisation, Boundary, GridParams};
//! let spectrum = SquareWaveParams::preset("spectrum3").unwrap().spectrum().unwrap();
//! let web = Web::new(
//!     WebParams { fibres_across: 80, segments_per_fibre: 8, belt_speed_ratio: 0.05, ..WebParams::default() },
//!     vec![spectrum],
//! ).unwrap();
//! // A small web folded onto a 0.4 m × 0.2 m torus; an open web this small would be
//! // rejected (the window would be within a few fibre spreads of its edges).
//! let grid = GridParams { window_side: 0.1, boundary: Boundary::Periodic, ..GridParams::default() };
//! let r = grid_realisation(&web, &grid, 0).unwrap();
//! assert_eq!(r.density.dim(), (100, 100));
//! // Interior areal density ρA/(Δw·c) = 2.39 g/m² (eq 16 in g/m²):
//! assert!((r.mean_areal_density_gsm / 2.388 - 1.0).abs() < 0.15, "{}", r.mean_areal_density_gsm);
//! ```
mod deposit;
pub mod laid;
mod stage;

pub use stage::{grid_params, GridStage, TABLE4, TABLE4_SOURCE};

pub use deposit::{Boundary, DensityGrid, Deposit, Period, QUANTA_PER_POINT};

use ndarray::Array2;
use rayon::prelude::*;
use std::sync::Mutex;

/// Fibres generated up front to reject a window that is clearly too close to an edge.
const PRECHECK_FIBRES: usize = 48;

use crate::params::{ParamError, ParamSpec};
use crate::stages::web::Web;
use crate::uniformity::{coefficient_of_variation, cv_by_zone_size, formation_number, log_zone_sizes, random_line_cv_squared};

/// Parameters of the density grid and its statistics.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GridParams {
    /// Δh (m), cell side.
    pub cell_size: f64,
    /// H (m), window side; must be a whole number of cells.
    pub window_side: f64,
    /// MD shift of the window centre from the middle of the drift c·n_l·L/2 (m).
    pub window_offset_md: f64,
    /// CD shift of the window centre from the web's centre line (m).
    pub window_offset_cd: f64,
    /// Required distance of the window from the web's edges and drift ends, in
    /// measured spreads (0 disables the check).
    pub edge_margin_spreads: f64,
    pub deposit: Deposit,
    /// Open (as laid, the paper) or periodic (folded onto a torus, no edges).
    pub boundary: Boundary,
    /// Smallest zone size of the CV curve (m); sizes below Δh are skipped.
    pub zone_size_min: f64,
    /// Largest zone size of the CV curve (m).
    pub zone_size_max: f64,
    /// Log-spaced zone sizes per doubling.
    pub zones_per_octave: usize,
}

impl Default for GridParams {
    fn default() -> Self {
        Self {
            cell_size: 1e-3,
            window_side: 0.5,
            window_offset_md: 0.0,
            window_offset_cd: 0.0,
            edge_margin_spreads: 3.0,
            deposit: Deposit::PointMass,
            boundary: Boundary::Open,
            zone_size_min: 0.5e-3,
            zone_size_max: 16e-3,
            zones_per_octave: 2,
        }
    }
}

/// Parameter table of [`GridParams`].
pub const GRID_PARAMS: &[ParamSpec] = &[
    ParamSpec::float("cell_size", "m", 1e-3, 1e-6, 1.0, "Δh, grid cell side (§3.3)"),
    ParamSpec::float("window_side", "m", 0.5, 1e-5, 100.0, "H, side of the square evaluation window; a whole number of cells"),
    ParamSpec::float("window_offset_md", "m", 0.0, -1e4, 1e4, "MD shift of the window centre from the middle of the drift c·n_l·L/2"),
    ParamSpec::float("window_offset_cd", "m", 0.0, -1e4, 1e4, "CD shift of the window centre from the web's centre line"),
    ParamSpec::float("edge_margin_spreads", "1", 3.0, 0.0, 100.0, "required window distance from web edges and drift ends, in measured fibre spreads (0 = no check)"),
    ParamSpec::choice("deposit", Deposit::NAMES, "point_mass", "point_mass: Δm per node (paper); segment_clipping: mass per chord split exactly between cells"),
    ParamSpec::choice("boundary", Boundary::NAMES, "open", "open: the web as laid (paper); periodic: folded onto the torus MD c·n_l·L × CD n_wΔw, no edges or run-in"),
    ParamSpec::float("zone_size_min", "m", 0.5e-3, 1e-6, 100.0, "smallest zone size of the CV curve (sizes below Δh are skipped)"),
    ParamSpec::float("zone_size_max", "m", 16e-3, 1e-6, 100.0, "largest zone size of the CV curve"),
    ParamSpec::int("zones_per_octave", "1", 2, 1, 64, "log-spaced zone sizes per doubling"),
];

/// Errors of the grid stage.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    #[error(transparent)]
    Param(#[from] ParamError),
    #[error("zone_size_min = {min} m exceeds zone_size_max = {max} m")]
    ZoneRange { min: f64, max: f64 },
    #[error("cell_size Δh = {cell_size} m does not divide window_side H = {window_side} m into whole cells (H/Δh = {ratio})")]
    CellDoesNotDivideWindow { cell_size: f64, window_side: f64, ratio: f64 },
    #[error("belt_speed_ratio c = 0: on a stationary belt the fibres pile up at their start, the web has no interior and its density grows with fibre length; use c > 0 (a web left `auto` takes c from its laid fibres, 0 for spectra that keep the belt motion: see its inherited_parameters, or set belt_speed_ratio)")]
    StationaryBelt,
    #[error("window {window_md} m (MD) × {window_cd} m (CD) at centre ({centre_md}, {centre_cd}) m does not lie inside the web's nominal extent: MD 0..{web_length} m (c·n_l·L), CD ±{half_width} m (n_wΔw/2)")]
    WindowOutsideWeb { window_md: f64, window_cd: f64, centre_md: f64, centre_cd: f64, web_length: f64, half_width: f64 },
    #[error(transparent)]
    Alloc(#[from] crate::memory::AllocError),
    #[error("window is {margin:.4} m from the web's {edge}, less than {required_spreads} × the fibre spread {spread:.4} m (RMS over {fibres} fibres) = {required:.4} m: the density there falls short of the interior value. Use a wider/longer web (n_w, n_l), a smaller window, or lower edge_margin_spreads knowingly")]
    WindowTooCloseToEdge { edge: &'static str, margin: f64, spread: f64, fibres: usize, required_spreads: f64, required: f64 },
}

impl GridParams {
    /// Checks ranges and that H is a whole number of cells; returns the cell count.
    pub fn validate(&self) -> Result<usize, GridError> {
        let t = GRID_PARAMS;
        ParamSpec::find(t, "cell_size").check_number(self.cell_size)?;
        ParamSpec::find(t, "window_side").check_number(self.window_side)?;
        ParamSpec::find(t, "window_offset_md").check_number(self.window_offset_md)?;
        ParamSpec::find(t, "window_offset_cd").check_number(self.window_offset_cd)?;
        ParamSpec::find(t, "edge_margin_spreads").check_number(self.edge_margin_spreads)?;
        ParamSpec::find(t, "zone_size_min").check_number(self.zone_size_min)?;
        ParamSpec::find(t, "zone_size_max").check_number(self.zone_size_max)?;
        ParamSpec::find(t, "zones_per_octave").check_number(self.zones_per_octave as f64)?;
        if self.zone_size_min > self.zone_size_max {
            return Err(GridError::ZoneRange { min: self.zone_size_min, max: self.zone_size_max });
        }
        let ratio = self.window_side / self.cell_size;
        let cells = ratio.round();
        if (ratio - cells).abs() > 1e-9 * ratio || cells < 1.0 {
            return Err(GridError::CellDoesNotDivideWindow { cell_size: self.cell_size, window_side: self.window_side, ratio });
        }
        Ok(cells as usize)
    }

    /// Lower corner (x_min, y_min) of the window for `web`, checked against the
    /// web's nominal extent (no generation needed).
    pub fn window_corner(&self, web: &Web) -> Result<(f64, f64), GridError> {
        self.validate()?;
        let p = web.params();
        if p.belt_speed_ratio == 0.0 {
            return Err(GridError::StationaryBelt);
        }
        let length = web.drift_length();
        let half_width = p.half_width();
        let centre_md = 0.5 * length + self.window_offset_md;
        let centre_cd = self.window_offset_cd;
        let h = 0.5 * self.window_side;
        if centre_md - h < 0.0 || centre_md + h > length || centre_cd.abs() + h > half_width {
            return Err(GridError::WindowOutsideWeb {
                window_md: self.window_side,
                window_cd: self.window_side,
                centre_md,
                centre_cd,
                web_length: length,
                half_width,
            });
        }
        Ok((centre_md - h, centre_cd - h))
    }
}

/// CV and formation number at one zone size.
#[derive(Debug, Clone, PartialEq)]
pub struct ZonePoint {
    /// Zone side actually used, cells_per_side·Δh (m).
    pub zone_size: f64,
    pub cells_per_side: usize,
    /// Number of zones the CV is taken over.
    pub zones: usize,
    pub cv: f64,
    /// CV of a random network of straight lines with the same L_A: √(E1/(π L_A x)).
    pub random_line_cv: f64,
    /// n_f = CV²/CV²_random.
    pub formation_number: f64,
}

/// Measured fibre spreads used by the window check (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spreads {
    /// σ_CD: RMS CD displacement at the arc length where the drift reaches the window's far edge.
    pub cross_direction: f64,
    /// σ_MD: RMS MD displacement of the fibre ends from c·n_l·L.
    pub machine_direction: f64,
}

/// Density grid and statistics of one realisation.
#[derive(Debug, Clone, PartialEq)]
pub struct GridResult {
    /// Areal density of each cell (kg/m²), rows = MD, columns = CD.
    pub density: Array2<f64>,
    /// ρ_av = Σ_k m_k / H² (eq 16), kg/m².
    pub mean_areal_density: f64,
    /// ρ_av in g/m².
    pub mean_areal_density_gsm: f64,
    /// CV of the cell densities.
    pub cv: f64,
    /// Interior value ρA/(Δw·c) the window should see (kg/m²).
    pub expected_interior_density: f64,
    /// L_A = ρ_av/(ρA): fibre length per area in the window (1/m).
    pub fibre_length_per_area: f64,
    pub zone_curve: Vec<ZonePoint>,
    /// Window lower corner (m).
    pub window_corner: [f64; 2],
    pub spreads: Spreads,
    /// Nodes generated for this realisation.
    pub nodes_generated: u64,
}

/// Generates realisation `realisation` of `web` (in parallel on the current rayon
/// pool, one fibre per worker at a time) and evaluates it on the window.
/// Bit-identical for any thread count.
pub fn grid_realisation(web: &Web, params: &GridParams, realisation: u32) -> Result<GridResult, GridError> {
    let cells = params.validate()?;
    let (x_min, y_min) = params.window_corner(web)?;
    let p = *web.params();
    let far_edge = x_min + params.window_side;
    let s_w = (far_edge / p.belt_speed_ratio).min(web.fibre_length());
    let k_w = ((s_w / web.spacing()).round() as usize).min(web.nodes_per_fibre() - 1);
    let drift_end = web.drift_length();
    let displacement = |nodes: &[[f64; 2]]| [nodes[k_w][1] - nodes[0][1], nodes[nodes.len() - 1][0] - drift_end];
    let rms = |d: &[[f64; 2]], c: usize| (d.iter().map(|d| d[c] * d[c]).sum::<f64>() / d.len() as f64).sqrt();
    if params.boundary == Boundary::Open && params.edge_margin_spreads > 0.0 && p.fibres_across > PRECHECK_FIBRES {
        // Cheap early failure: spreads of a few evenly spaced fibres, with 20 % leeway
        // for their sampling error; the full set decides below.
        let sample: Vec<[f64; 2]> = (0..PRECHECK_FIBRES)
            .into_par_iter()
            .map(|i| displacement(&web.generate_fibre(realisation, i * p.fibres_across / PRECHECK_FIBRES)))
            .collect();
        let rough = Spreads { cross_direction: rms(&sample, 0), machine_direction: rms(&sample, 1) };
        check_margins(params, &p, x_min, y_min, drift_end, &rough, 0.8, PRECHECK_FIBRES)?;
    }
    let mut grid = DensityGrid::try_new(x_min, y_min, params.cell_size, cells)?;
    if params.boundary == Boundary::Periodic {
        grid = grid.with_period(Period {
            origin: [0.0, -p.half_width()],
            period: [web.drift_length(), 2.0 * p.half_width()],
        });
    }
    // Per-fibre displacements, stored by index and summed in order (deterministic). A
    // fibre may come in pieces (consecutive ones share a node, so each chord and each
    // deposited node is in one piece), in order: its start is read before node k_w, and
    // −y_0 + y_{k_w} is `displacement`'s y_{k_w} − y_0 to the bit.
    let n_w = p.fibres_across;
    let last = web.nodes_per_fibre() - 1;
    let displacements = Mutex::new(crate::memory::try_vec(n_w, [0.0f64; 2], "the fibres' displacements")?);
    web.par_for_each_fibre_piece(realisation, |j, first, nodes| {
        grid.deposit_fibre(nodes, params.deposit);
        let end = first + nodes.len() - 1;
        let holds_k_w = (first..=end).contains(&k_w);
        if first == 0 || holds_k_w || end == last {
            let mut d = displacements.lock().unwrap();
            if first == 0 {
                d[j][0] = -nodes[0][1];
            }
            if holds_k_w {
                d[j][0] += nodes[k_w - first][1];
            }
            if end == last {
                d[j][1] = nodes[nodes.len() - 1][0] - drift_end;
            }
        }
    });
    let displacements = displacements.into_inner().unwrap();
    let spreads = Spreads { cross_direction: rms(&displacements, 0), machine_direction: rms(&displacements, 1) };
    if params.boundary == Boundary::Open {
        check_margins(params, &p, x_min, y_min, drift_end, &spreads, 1.0, n_w)?;
    }

    let stats = grid_statistics(&grid, web.point_mass(), p.mass_per_length(), params);
    Ok(GridResult {
        expected_interior_density: p.interior_areal_density(),
        window_corner: [x_min, y_min],
        spreads,
        nodes_generated: (n_w * web.nodes_per_fibre()) as u64,
        ..stats
    })
}

/// The density map of a filled grid and its statistics: ρ_av (eq 16), CV, CV by zone
/// size and formation number. `point_mass` is the mass a node deposits (kg) and
/// `mass_per_length` ρA (kg/m). Window corner, spreads, expected density and node
/// count are left zero for the caller.
pub fn grid_statistics(grid: &DensityGrid, point_mass: f64, mass_per_length: f64, params: &GridParams) -> GridResult {
    let area = params.cell_size * params.cell_size;
    let density = grid.masses(point_mass) / area;
    let mean = density.iter().sum::<f64>() / density.len() as f64; // = Σ m_k / H² (eq 16)
    let cv = coefficient_of_variation(density.iter().copied());
    let fibre_length_per_area = mean / mass_per_length;
    let zone_sizes = log_zone_sizes(params.zone_size_min, params.zone_size_max, params.zones_per_octave);
    let zone_curve = cv_by_zone_size(density.view(), params.cell_size, &zone_sizes)
        .into_iter()
        .map(|z| {
            let x = z.cells_per_side as f64 * params.cell_size;
            ZonePoint {
                zone_size: x,
                cells_per_side: z.cells_per_side,
                zones: z.zones,
                cv: z.cv,
                random_line_cv: random_line_cv_squared(fibre_length_per_area, x).sqrt(),
                formation_number: formation_number(z.cv, fibre_length_per_area, x),
            }
        })
        .collect();
    GridResult {
        density,
        mean_areal_density: mean,
        mean_areal_density_gsm: mean * 1e3,
        cv,
        expected_interior_density: 0.0,
        fibre_length_per_area,
        zone_curve,
        window_corner: [0.0; 2],
        spreads: Spreads { cross_direction: 0.0, machine_direction: 0.0 },
        nodes_generated: 0,
    }
}

fn check_margins(
    params: &GridParams,
    p: &crate::stages::web::WebParams,
    x_min: f64,
    y_min: f64,
    drift_end: f64,
    spreads: &Spreads,
    leeway: f64,
    fibres: usize,
) -> Result<(), GridError> {
    let k = params.edge_margin_spreads;
    if k == 0.0 {
        return Ok(());
    }
    let h = params.window_side;
    let w = p.half_width();
    let checks = [
        ("lower CD edge", y_min + w, spreads.cross_direction),
        ("upper CD edge", w - (y_min + h), spreads.cross_direction),
        ("start of the drift (x = 0)", x_min, spreads.machine_direction),
        ("end of the drift (x = c·n_l·L)", drift_end - (x_min + h), spreads.machine_direction),
    ];
    for (edge, margin, spread) in checks {
        if margin < leeway * k * spread {
            return Err(GridError::WindowTooCloseToEdge { edge, margin, spread, fibres, required_spreads: k, required: k * spread });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
