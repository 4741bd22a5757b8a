//! `kind: spectra` — the pipeline stage around the spectra numerics: curvature spectra
//! of laid fibres (input: a laydown stage, one fibre per valid replicate; or a laid_web
//! stage, every valid fibre of every replicate) or idealised square-wave spectra (no input).
//!
//! **Memory** ([`Stage::estimate_memory`]): every spectrum's samples are kept until the
//! output is written ([`ROW_BYTES_PER_SAMPLE`]), beside the output's arrays, padded to the
//! most spectra and the longest N ([`OUTPUT_BYTES_PER_SAMPLE`]); the input's laid nodes read whole
//! ([`INPUT_BYTES_PER_NODE`]); N is `points_per_segment`, or at most the fibre length
//! over `sample_spacing`.
use crate::error::InvalidParam;
use super::{analyse_fibres, CurvatureSpectrum, SpectraParams, SquareWaveParams, SPECTRA_PARAMS, SQUARE_WAVE_PARAMS};
use crate::archive::data::Output;
use crate::memory::Estimate;
use crate::params::{ParamSet, ParamSpec};
use crate::stages::{BadInput, Declared, InputRule, RunContext, Stage};
use anyhow::{anyhow, Result};
use ndarray::{Array1, Array2, Axis};
use num_complex::Complex64;

pub struct SpectraStage;

const PRESETS: &[&str] = &["none", "spectrum1", "spectrum2", "spectrum3"];

/// Bytes per sample of one spectrum's row: K_r (complex), κ, θ and a random realisation
/// (complex), 48 B, rounded up.
const ROW_BYTES_PER_SAMPLE: f64 = 56.0;
/// Bytes per sample of the output: K_r real and imaginary, S_r, κ and θ.
const OUTPUT_BYTES_PER_SAMPLE: f64 = 40.0;
/// Bytes per laid node of the input: the stored positions, landing time and belt-removed
/// x read whole, and the fibre copied out of them.
const INPUT_BYTES_PER_NODE: f64 = 72.0;

/// A spectra point's parameters ([`ParamSet::to_typed`] of the stage's table): the
/// analysis of laid fibres ([`SpectraParams`]), or an idealised square-wave spectrum.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpectraStageParams {
    pub preset: String,
    pub belt_removed: bool,
    /// [`SquareWaveParams`] but N, which is the analysis's `points_per_segment`.
    pub bending_energy: f64,
    pub cutoff_number: usize,
    pub segment_length: f64,
    #[serde(flatten)]
    pub analysis: SpectraParams,
}

impl SpectraStageParams {
    /// A point's typed parameters (its rows were checked against the table).
    pub fn of(p: &ParamSet) -> Self {
        p.to_typed().expect("the spectra table and SpectraStageParams agree (tested)")
    }
    /// N of an idealised spectrum: the given one, else 1000.
    fn idealised_points(&self) -> usize {
        match self.analysis.points_per_segment {
            0 => 1000,
            n => n,
        }
    }
}

/// The spectra of a declared spectra stage, per output point: (spectra, N samples each).
pub fn declared_spectra(stage: &Declared) -> Vec<(f64, f64)> {
    let p = SpectraStageParams::of(&stage.points[0]);
    let given = p.analysis.points_per_segment as f64;
    let laid = match stage.inputs.first() {
        Some(input) if input.kind == "laid_web" => crate::stages::laid_web::stage::declared_fibres(input),
        Some(input) => crate::stages::laydown::declared_fibres(input),
        None => {
            return stage
                .points
                .iter()
                .map(|p| {
                    let p = SpectraStageParams::of(p);
                    let n = if p.preset == "none" { p.idealised_points() } else { 1000 };
                    (stage.replicates as f64, n as f64)
                })
                .collect()
        }
    };
    let spacing = p.analysis.sample_spacing;
    laid.iter().map(|f| (f.count, if given > 0.0 { given } else { (f.length / spacing).floor() + 1.0 })).collect()
}

/// One spectrum with what produced it.
struct Row {
    spectrum: CurvatureSpectrum,
    curvature: Vec<f64>,
    tangent_angle: Vec<f64>,
    /// A laid fibre's nodes resampled at s_m = mΔs, N + 1 (empty for idealised spectra).
    resampled: Vec<[f64; 2]>,
    e_from_curvature: f64,
    valid: bool,
}

impl Stage for SpectraStage {
    fn kind(&self) -> &'static str {
        "spectra"
    }
    fn summary(&self) -> &'static str {
        "curvature spectra K_r, S_r of laid fibres (eqs 9-10) or idealised square-wave spectra (eqs A.1-A.5)"
    }
    fn cache_version(&self) -> u32 {
        1
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &["laydown", "laid_web"], min: 0, max: 1 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v = vec![
            ParamSpec::choice("preset", PRESETS, "none", "idealised source: the paper's Fig 10 spectra (sets bending_energy, cutoff_number; L = 1 m, N = 1000)"),
            ParamSpec::flag("belt_removed", true, "laid-fibre source: analyse positions with the belt motion removed (the web stage adds the belt drift by eq 14)"),
        ];
        for p in SQUARE_WAVE_PARAMS {
            if p.name == "points_per_segment" {
                continue;
            }
            v.push(*p);
        }
        v.extend_from_slice(SPECTRA_PARAMS);
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), InvalidParam> {
        let p = SpectraStageParams::of(p);
        if p.preset == "none" {
            let (n, nc) = (p.idealised_points(), p.cutoff_number);
            if 2 * nc >= n {
                return Err(InvalidParam::new("cutoff_number".into(), format!("n_c = {nc} is at or beyond the Nyquist bin N/2 = {} for N = {n}; allowed: 2·n_c < N", n / 2)));
            }
        }
        Ok(())
    }

    fn estimate_memory(&self, stage: &Declared) -> Option<Estimate> {
        let spectra = declared_spectra(stage);
        let samples: f64 = spectra.iter().map(|(n, s)| n * s).sum();
        let (count, longest) = (spectra.iter().map(|s| s.0).sum::<f64>(), spectra.iter().map(|s| s.1).fold(0.0, f64::max));
        let (input, params, inverse): (f64, &[&str], &[&str]) = match stage.inputs.first() {
            Some(i) => {
                let laid = match i.kind.as_str() {
                    "laid_web" => crate::stages::laid_web::stage::declared_fibres(i),
                    _ => crate::stages::laydown::declared_fibres(i),
                };
                (laid.iter().map(|f| f.count * f.nodes * INPUT_BYTES_PER_NODE).sum(), &["points_per_segment"], &["sample_spacing"])
            }
            None if stage.points.iter().all(|p| SpectraStageParams::of(p).preset != "none") => (0.0, &["replicates"], &[]),
            None => (0.0, &["points_per_segment", "replicates"], &[]),
        };
        let most = spectra.iter().map(|s| s.0).fold(0.0, f64::max);
        let output = spectra.len() as f64 * most * longest * OUTPUT_BYTES_PER_SAMPLE;
        let what = format!("{count} spectra of up to N = {longest} samples, {ROW_BYTES_PER_SAMPLE} B each, and the output padded to {most} × {longest} per point, {OUTPUT_BYTES_PER_SAMPLE} B each");
        Some(Estimate::new(samples * ROW_BYTES_PER_SAMPLE + output + input, what, &stage.name, params).falling_with(&stage.name, inverse))
    }

    fn run(&self, ctx: &RunContext) -> Result<Output> {
        let rows: Vec<Vec<Row>> = if ctx.inputs.is_empty() {
            ctx.points.iter().map(|p| idealised(ctx, p)).collect::<Result<_>>()?
        } else {
            if !ctx.sweep.is_empty() {
                return Err(BadInput("a spectra stage reading laid fibres takes the input's sweep points; it cannot have a sweep of its own".into()).into());
            }
            laid(ctx, &ctx.points[0])?
        };
        let mut out = assemble(&rows)?;
        if let Some(input) = ctx.inputs.first() {
            laid_fibre_parameters(input, rows.len(), SpectraStageParams::of(&ctx.points[0]).belt_removed, &mut out)?;
        }
        Ok(out)
    }
}

/// Records per point the physical parameters of the laid fibres analysed (d, ρ, c =
/// v_b/v_f), which a web built on these spectra takes unless its pipeline sets them, and
/// whether the belt motion was removed.
fn laid_fibre_parameters(input: &crate::stages::Input, points: usize, belt_removed: bool, out: &mut Output) -> Result<()> {
    let per_point = |name: &str| -> Result<Array1<f64>> {
        let values = input.parameter_per_point(name, points)?.ok_or_else(|| anyhow!("{} {} records no parameter `{name}`", input.kind, input.version.group_path()))?;
        Ok(Array1::from(values))
    };
    let (belt_speed, fibre_speed) = (per_point("belt_speed")?, per_point("fibre_speed")?);
    out.f64("fibre_diameter", &["point"], per_point("diameter")?, "m", "d of the laid fibres");
    out.f64("fibre_density", &["point"], per_point("density")?, "kg m-3", "ρ of the laid fibres");
    out.f64("belt_speed_ratio", &["point"], &belt_speed / &fibre_speed, "1", "c = v_b/v_f the fibres were laid at");
    out.i64("input_point", &["point"], Array1::from_iter(0..points as i64), "1", "input point").describe("point of the input whose laid fibres are analysed");
    out.flags("belt_removed", &[], ndarray::arr0(belt_removed), "belt motion removed").describe("the fibres were analysed with the belt motion removed (as their stage's belt_removal takes it off)");
    Ok(())
}

fn idealised(ctx: &RunContext, p: &ParamSet) -> Result<Vec<Row>> {
    let p = SpectraStageParams::of(p);
    let sq = match p.preset.as_str() {
        "none" => SquareWaveParams { bending_energy: p.bending_energy, cutoff_number: p.cutoff_number, segment_length: p.segment_length, points_per_segment: p.idealised_points() },
        name => SquareWaveParams::preset(name).ok_or_else(|| anyhow!("unknown preset {name}"))?,
    };
    let spectrum = sq.spectrum().map_err(|e| BadInput(e.to_string()))?;
    // One random realisation per replicate (eqs 11-13), to show κ(s) and check e.
    Ok((0..ctx.replicates)
        .map(|rep| {
            let mut rng = ctx.rng(rep, 0);
            let realised = spectrum.with_random_phases(&mut rng);
            let curvature = realised.curvature();
            let tangent_angle = super::tangent_angles(&curvature, spectrum.spacing(), 0.0);
            let e = realised.bending_energy();
            Row { spectrum: spectrum.clone(), curvature, tangent_angle, resampled: vec![], e_from_curvature: e, valid: true }
        })
        .collect())
}

/// One row per sweep point of the input, each with one spectrum per laid fibre.
fn laid(ctx: &RunContext, p: &ParamSet) -> Result<Vec<Vec<Row>>> {
    let input = ctx.input(0);
    let SpectraStageParams { belt_removed, analysis: params, .. } = SpectraStageParams::of(p);
    params.validate().map_err(|e| BadInput(e.to_string()))?;
    let points = match input.kind.as_str() {
        "laid_web" => laid_web_fibres(input, belt_removed)?,
        _ => laydown_fibres(input, belt_removed)?,
    };
    let mut out = vec![];
    for (pt, (fibres, which)) in points.into_iter().enumerate() {
        if fibres.is_empty() {
            return Err(BadInput(format!("{} {} point {pt} has no valid fibre (all were rejected); nothing to analyse", input.kind, input.version.group_path())).into());
        }
        let analyses = analyse_fibres(&fibres, &params)
            .map_err(|(i, e)| BadInput(format!("{} {} point {pt} {}: {e}", input.kind, input.version.group_path(), which[i])))?;
        out.push(
            analyses
                .into_iter()
                .map(|a| Row {
                    tangent_angle: a.signal.tangent_angles(),
                    resampled: a.signal.resampled.clone(),
                    curvature: a.signal.curvature.clone(),
                    e_from_curvature: a.bending_energy_samples,
                    spectrum: a.spectrum,
                    valid: true,
                })
                .collect(),
        );
    }
    Ok(out)
}

/// Per point: the valid laid fibres and what each is (for messages).
type PointFibres = Vec<(Vec<Vec<[f64; 3]>>, Vec<String>)>;

/// A laydown stage's valid replicates, one fibre each.
fn laydown_fibres(input: &crate::stages::Input, belt_removed: bool) -> Result<PointFibres> {
    let name = if belt_removed { "laid_positions_belt_removed" } else { "laid_positions" };
    let positions = input.read_f64(name)?; // (point, replicate, node, xyz)
    let valid = input.read_u8("valid")?; // (point, replicate)
    let (npoints, nreps) = (positions.shape()[0], positions.shape()[1]);
    Ok((0..npoints)
        .map(|pt| {
            let (mut fibres, mut which) = (vec![], vec![]);
            for r in (0..nreps).filter(|&r| valid[[pt, r]] != 0) {
                let nodes: Vec<[f64; 3]> = positions
                    .index_axis(Axis(0), pt)
                    .index_axis(Axis(0), r)
                    .outer_iter()
                    .map(|n| [n[0], n[1], n[2]])
                    .filter(|n| n.iter().all(|v| v.is_finite()))
                    .collect();
                fibres.push(nodes);
                which.push(format!("replicate {r}"));
            }
            (fibres, which)
        })
        .collect())
}

/// A laid web's valid fibres of every replicate, projected on the belt plane; belt
/// removed: the x the laid web stored (`laid_x_belt_removed`, by its `belt_removal`).
fn laid_web_fibres(input: &crate::stages::Input, belt_removed: bool) -> Result<PointFibres> {
    let positions = input.read_f64("laid_positions")?; // (point, replicate, laid_node, xyz)
    let start = input.read_i64("fibre_node_start")?; // (point, replicate, fibre)
    let count = input.read_i64("fibre_laid_nodes")?;
    let valid = input.read_u8("valid")?;
    // x with the belt motion removed, as the laid web measured its belt-removed S and e.
    let x = match (belt_removed, input.has("laid_x_belt_removed")) {
        (false, _) => positions.index_axis(Axis(3), 0).to_owned(),
        (true, true) => input.read_f64("laid_x_belt_removed")?,
        (true, false) => {
            // A laid web written before it stored them: its belt removal by landing time.
            let (landing, belt_speed, feed_time) = (input.read_f64("landing_time")?, input.read_f64("belt_speed")?, input.read_f64("feed_time")?);
            ndarray::Array::from_shape_fn(landing.raw_dim(), |ix| {
                let pt = ix[0];
                positions[[pt, ix[1], ix[2], 0]] - belt_speed[[pt]] * (feed_time[[pt]] - landing[&ix])
            })
        }
    };
    let (npoints, nreps, nf) = (start.shape()[0], start.shape()[1], start.shape()[2]);
    Ok((0..npoints)
        .map(|pt| {
            let (mut fibres, mut which) = (vec![], vec![]);
            for r in 0..nreps {
                for j in (0..nf).filter(|&j| valid[[pt, r, j]] != 0 && start[[pt, r, j]] >= 0) {
                    let a = start[[pt, r, j]] as usize;
                    let nodes = (a..a + count[[pt, r, j]] as usize).map(|k| [x[[pt, r, k]], positions[[pt, r, k, 1]], 0.0]).collect();
                    fibres.push(nodes);
                    which.push(format!("replicate {r} fibre {j}"));
                }
            }
            (fibres, which)
        })
        .collect())
}

fn assemble(rows: &[Vec<Row>]) -> Result<Output> {
    let npoints = rows.len();
    let nfibres = rows.iter().map(|r| r.len()).max().unwrap_or(0);
    let nbins = rows.iter().flatten().map(|r| r.spectrum.points()).max().unwrap_or(0);
    let nangles = rows.iter().flatten().map(|r| r.tangent_angle.len()).max().unwrap_or(0);
    let nan = f64::NAN;
    let what = "the spectra";
    let mut re = crate::memory::try_array((npoints, nfibres, nbins), nan, what)?;
    let mut im = crate::memory::try_array((npoints, nfibres, nbins), nan, what)?;
    let mut energy = crate::memory::try_array((npoints, nfibres, nbins), nan, what)?;
    let mut kappa = crate::memory::try_array((npoints, nfibres, nbins), nan, what)?;
    let mut theta = crate::memory::try_array((npoints, nfibres, nangles), nan, what)?;
    let nnodes = rows.iter().flatten().map(|r| r.resampled.len()).max().unwrap_or(0);
    let mut resampled = if nnodes > 0 { Some(crate::memory::try_array((npoints, nfibres, nnodes, 2), nan, what)?) } else { None };
    let mut e_k = Array2::from_elem((npoints, nfibres), nan);
    let mut e_s = e_k.clone();
    let mut valid = Array2::from_elem((npoints, nfibres), false);
    let mut mean_re = Array2::from_elem((npoints, nbins), nan);
    let mut mean_im = mean_re.clone();
    let mut mean_energy = mean_re.clone();
    let mut spacing = Array1::from_elem(npoints, nan);
    let mut length = spacing.clone();
    let mut omega = Array2::from_elem((npoints, nbins), nan);
    for (p, fibres) in rows.iter().enumerate() {
        for (f, row) in fibres.iter().enumerate() {
            let s = &row.spectrum;
            for (r, c) in s.coefficients().iter().enumerate() {
                re[[p, f, r]] = c.re;
                im[[p, f, r]] = c.im;
                energy[[p, f, r]] = c.norm_sqr();
            }
            for (m, k) in row.curvature.iter().enumerate() {
                kappa[[p, f, m]] = *k;
            }
            for (m, t) in row.tangent_angle.iter().enumerate() {
                theta[[p, f, m]] = *t;
            }
            if let Some(r) = resampled.as_mut() {
                for (m, q) in row.resampled.iter().enumerate() {
                    r[[p, f, m, 0]] = q[0];
                    r[[p, f, m, 1]] = q[1];
                }
            }
            e_k[[p, f]] = row.e_from_curvature;
            e_s[[p, f]] = s.bending_energy();
            valid[[p, f]] = row.valid;
        }
        let spectra: Vec<CurvatureSpectrum> = fibres.iter().map(|r| r.spectrum.clone()).collect();
        if let Ok(mean) = CurvatureSpectrum::mean(&spectra) {
            for (r, c) in mean.coefficients().iter().enumerate() {
                let c: &Complex64 = c;
                mean_re[[p, r]] = c.re;
                mean_im[[p, r]] = c.im;
                mean_energy[[p, r]] = c.norm_sqr();
                omega[[p, r]] = mean.angular_frequency(r);
            }
            spacing[p] = mean.spacing();
            length[p] = mean.segment_length();
        }
    }
    let mut out = Output::new();
    out.i64("bin", &["bin"], Array1::from_iter(0..nbins as i64), "1", "DFT index r").describe("DFT index r (eq 10); r > N/2 are the negative frequencies r − N");
    out.f64("angular_frequency", &["point", "bin"], omega, "rad m-1", "ω_r = 2πr/L (signed: r − N for r > N/2)");
    out.f64("curvature_spectrum_real", &["point", "fibre", "bin"], re, "m-1", "real part of K_r (eq 10)");
    out.f64("curvature_spectrum_imag", &["point", "fibre", "bin"], im, "m-1", "imaginary part of K_r (eq 10)");
    out.f64("energy_spectrum", &["point", "fibre", "bin"], energy, "m-2", "S_r = |K_r|^2");
    out.f64("mean_curvature_spectrum_real", &["point", "bin"], mean_re, "m-1", "mean curvature spectrum, real part").describe("energy-averaged spectrum over fibres: sqrt(mean S_r), zero phase (r = 0 keeps the mean curvature's sign)");
    out.f64("mean_curvature_spectrum_imag", &["point", "bin"], mean_im, "m-1", "imaginary part of the mean spectrum (zero)");
    out.f64("mean_energy_spectrum", &["point", "bin"], mean_energy, "m-2", "mean S_r over fibres");
    out.f64("curvature", &["point", "fibre", "sample"], kappa, "m-1", "κ_m at s_m = mΔs (eq 9)");
    out.f64("tangent_angle", &["point", "fibre", "angle_sample"], theta, "rad", "tangent angle θ_m").describe("θ_m, unwrapped tangent angle in the belt plane (x = machine direction)");
    if let Some(r) = resampled {
        out.f64("resampled_position", &["point", "fibre", "node", "xy"], r, "m", "resampled laid nodes").describe("laid fibre's nodes in the belt plane at s_m = mΔs, m = 0..N, as analysed (belt removed with belt_removed); NaN padding");
        out.strings("xy", "xy", vec!["x".into(), "y".into()], "axis").describe("axis: x machine direction (belt motion), y cross direction");
    }
    out.f64("bending_energy_from_curvature", &["point", "fibre"], e_k, "1", "e = (L/2) Σ κ_m² Δs (eqs 6, A.3)");
    out.f64("bending_energy_from_spectrum", &["point", "fibre"], e_s, "1", "e = (L²/2) Σ S_r (Parseval, eq A.4)");
    out.flags("valid", &["point", "fibre"], valid, "spectrum present (padding is false)");
    let arc = Array2::from_shape_fn((npoints, nbins), |(p, m)| m as f64 * spacing[p]);
    let arc_angle = Array2::from_shape_fn((npoints, nangles), |(p, m)| m as f64 * spacing[p]);
    out.f64("arc_length", &["point", "sample"], arc, "m", "s_m = mΔs of each curvature sample (eq 9)");
    out.f64("angle_arc_length", &["point", "angle_sample"], arc_angle, "m", "arc length of each tangent-angle sample");
    for v in out.variables.iter_mut() {
        let c = match v.dims.last().map(|d| d.as_str()) {
            Some("sample") if v.name != "arc_length" => "arc_length",
            Some("angle_sample") if v.name != "angle_arc_length" => "angle_arc_length",
            Some("bin") if v.name != "angular_frequency" && v.name != "bin" => "angular_frequency",
            _ => continue,
        };
        v.attrs.insert("coordinates".into(), crate::archive::data::Attr::Str(c.into()));
    }
    out.f64("sample_spacing", &["point"], spacing, "m", "Δs, arc-length spacing of the samples");
    out.f64("segment_length", &["point"], length, "m", "L = NΔs, length of the analysed fibre or segment");
    Ok(out)
}

impl CurvatureSpectrum {
    /// A random realisation with the same magnitudes (eq 11): K'_r = |K_r| e^{iθ_r},
    /// θ_r uniform in [0, 2π), θ_{−r} = −θ_r; K_0 and K_{N/2} keep their (real) values.
    pub fn with_random_phases(&self, rng: &mut impl rand::Rng) -> CurvatureSpectrum {
        let k = self.coefficients();
        let n = k.len();
        let mut out = k.to_vec();
        for r in 1..n.div_ceil(2) {
            let phase: f64 = rng.random::<f64>() * std::f64::consts::TAU;
            out[r] = Complex64::from_polar(k[r].norm(), phase);
            out[n - r] = out[r].conj();
        }
        CurvatureSpectrum::new(self.segment_length(), out).expect("same shape as a valid spectrum")
    }
}
