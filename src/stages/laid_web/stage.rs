//! The `laid_web` pipeline stage. A unit of work is one web, (point, replicate); its
//! fibres run in parallel. Outputs, on (point, replicate) like every stage:
//!
//! - `laid_positions` (point, replicate, laid_node, xyz): the landed nodes of every
//!   fibre in belt coordinates at the end of the run (x from the feed point's MD
//!   position, y with the fibre's feed offset, not folded onto the CD period), fibre
//!   after fibre; fibre j occupies `fibre_node_start[j] .. + fibre_laid_nodes[j]`;
//!   `landing_time` (point, replicate, laid_node) the time each first touched the belt;
//! - per fibre (point, replicate, fibre): S and e raw and belt removed, `valid`,
//!   oscillation `phase`, `frozen_nodes`, `final_lift_of_landed`, `node_steps`, ...;
//! - per web: `interior_md_min`/`interior_md_max` (the MD range free of start-up and
//!   touchdown), `cd_period`, `spread`; per point: `expected_interior_density`,
//!   `element_length`, `mass_per_length`, `feed_time`, `broad_phase_interval`.
//!
//! Before a run, `validate` prints each point's estimated CPU time
//! ([`LaidWebParams::estimated_cpu_seconds`]; "at least" with fibre contact), and
//! `--max-cpu-time` refuses a stage above it ([`crate::run_time`]).
use crate::error::InvalidParam;
use super::{lay_web, FibreContactSettings, LaidWeb, LaidWebParams, Turbulence};
use crate::archive::data::Output;
use crate::params::{ParamCaution, ParamSet, ParamSpec};
use crate::rod::feed::FeedSettings;
use crate::rod::LaydownParams;
use crate::memory::Estimate;
use crate::stages::laydown::SIM_BYTES_PER_NODE;
use crate::stages::laydown::LaydownStage;
use crate::stages::rows::{self as get, place};
use crate::stages::{concurrent, Declared, DeclaredFibres, InputRule, RunContext, Stage, Units, UNIT_DIM};
use anyhow::{bail, Result};
use ndarray::{Array1, Array2, ArrayD};

pub struct LaidWebStage;

/// Parameters of the laydown stage that a laid web sets itself.
pub(crate) const NOT_FROM_LAYDOWN: &[&str] = &["length", "elements", "duration", "diagnostic_stride", "valid_replicates_target", "max_replicates", "mesh_error_estimate", "step_error_estimate", "start"];

/// Bytes per laid node until the output is written: the fed fibre's positions and
/// landing time, its row and the copy placed on (point, replicate), 32 B each, the write
/// buffer, and the belt-removed x (8 B).
const KEPT_BYTES_PER_NODE: f64 = 136.0;

/// Bytes per simulated node of a rod's fibre contact state: its per-node flags, saved
/// inverse masses, shifts and predicted velocities (about 110 B), and its candidates and
/// obstacle copies (136 B each, a few per node), with the broad phase's grid entries.
const CONTACT_BYTES_PER_NODE: f64 = 1024.0;

/// A laid-web point's parameters as the pipeline gives them ([`ParamSet::to_typed`] of
/// the stage's table): the laydown's scene but for `NOT_FROM_LAYDOWN` (their fields
/// keep their defaults until [`LaidWebParams`] sets them) and the laid web's own rows.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LaidWebStageParams {
    #[serde(flatten)]
    pub scene: LaydownParams,
    pub fibres_across: usize,
    pub fibre_spacing: f64,
    pub belt_travel: f64,
    pub element_length: f64,
    pub turbulence: Turbulence,
    pub frequency_jitter: f64,
    pub amplitude_jitter: f64,
    pub edge_margin_spreads: f64,
    pub freeze: bool,
    pub settle_time: f64,
    pub freeze_front_margin: f64,
    pub oscillation_ramp: f64,
    pub fibre_contact: bool,
    pub fibre_friction: f64,
    pub contact_interval: f64,
    pub self_contact: bool,
    pub contact_step_factor: f64,
}

/// The typed parameters of one sweep point (its rows were checked against the table).
pub fn laid_web_params(p: &ParamSet) -> LaidWebParams {
    stage_params(p).into()
}

/// The stage's rows of one sweep point, typed.
fn stage_params(p: &ParamSet) -> LaidWebStageParams {
    p.to_typed().expect("the laid_web table and LaidWebStageParams agree (tested)")
}

impl From<LaidWebStageParams> for LaidWebParams {
    fn from(p: LaidWebStageParams) -> Self {
        LaidWebParams {
            scene: p.scene,
            fibres_across: p.fibres_across,
            fibre_spacing: p.fibre_spacing,
            belt_travel: p.belt_travel,
            element_length: p.element_length,
            turbulence: p.turbulence,
            frequency_jitter: p.frequency_jitter,
            amplitude_jitter: p.amplitude_jitter,
            edge_margin_spreads: p.edge_margin_spreads,
            feed: FeedSettings { freeze: p.freeze, settle_time: p.settle_time, oscillation_ramp: p.oscillation_ramp, front_margin: p.freeze_front_margin, ..FeedSettings::default() },
            fibre_contact: p.fibre_contact.then_some(FibreContactSettings { friction: p.fibre_friction, interval: p.contact_interval, self_contact: p.self_contact, step_factor: p.contact_step_factor }),
        }
    }
}

/// The fibres of a declared laid_web stage, per point: every fibre of every replicate,
/// each as long as the fed length (an upper bound of what lands).
pub fn declared_fibres(stage: &Declared) -> Vec<DeclaredFibres> {
    stage
        .points
        .iter()
        .map(|p| {
            let lw = laid_web_params(p);
            DeclaredFibres { count: (stage.replicates * lw.fibres_across) as f64, nodes: lw.nodes_per_web() / lw.fibres_across as f64, length: lw.fed_length() }
        })
        .collect()
}

impl Stage for LaidWebStage {
    fn kind(&self) -> &'static str {
        "laid_web"
    }
    fn summary(&self) -> &'static str {
        "a web laid by the fibre physics: n_w fibres fed continuously onto the moving belt, CD periodic, stuck fibre frozen"
    }
    fn cache_version(&self) -> u32 {
        2
    }
    fn inputs(&self) -> InputRule {
        InputRule { kinds: &[], min: 0, max: 0 }
    }
    fn params(&self) -> Vec<ParamSpec> {
        let mut v: Vec<ParamSpec> = LaydownStage.params().into_iter().filter(|s| !NOT_FROM_LAYDOWN.contains(&s.name)).collect();
        v.push(ParamSpec::int("fibres_across", "1", 8, 1, 1_000_000, "n_w, fibres (spinneret holes) across the row; the CD period is n_w·fibre_spacing"));
        v.push(ParamSpec::float("fibre_spacing", "m", 2e-3, 1e-6, 1.0, "Δw, CD distance between the spinneret holes"));
        v.push(ParamSpec::float("belt_travel", "m", 0.05, 1e-4, 100.0, "B, belt length laid: the run lasts B/belt_speed"));
        v.push(ParamSpec::float("element_length", "m", 1e-3, 1e-6, 0.1, "Δs, rod element length (refined by coil_resolution)"));
        v.push(ParamSpec::choice("turbulence", Turbulence::NAMES, "independent", "independent: each fibre its own oscillation phase (and jitter); coherent: one for the whole row"));
        v.push(ParamSpec::float("frequency_jitter", "1", 0.0, 0.0, 0.3, "relative standard deviation of each fibre's oscillation frequency"));
        v.push(ParamSpec::float("amplitude_jitter", "1", 0.0, 0.0, 0.9, "relative standard deviation of each fibre's oscillation amplitude"));
        v.push(ParamSpec::float("edge_margin_spreads", "1", 3.0, 0.0, 100.0, "interior MD range: this many belt-removed spreads from the touchdown and from the start-up"));
        v.push(ParamSpec::flag("freeze", true, "freeze settled laid nodes (crept < 1 % of an element relative to the belt for settle_time, or laid 0.2 s ago, or past the freezing front: freeze_front_margin): carried with the belt at no cost"));
        v.push(ParamSpec::float("settle_time", "s", 0.02, 0.0, 10.0, "time a laid node must stay put on the belt (creep below 1 % of an element), and the least time since it landed, before it may freeze; shorter is cheaper and reads e higher (at 50 m/s 0.2 ms lays a web in 0.14x the node-steps of 20 ms, e about 2 % high)"));
        v.push(ParamSpec::float("freeze_front_margin", "m", FeedSettings::FRONT_MARGIN, 0.0, 1.0, "a laid node this far downstream of the farthest touchdown point reached so far (no fibre lands there; with fibre_contact of any fibre, without it the fibre's own, and then only a node on the belt) freezes after settle_time even if it still creeps; larger freezes later, 1 m switches the rule off"));
        v.push(ParamSpec::float("oscillation_ramp", "s", 0.0, 0.0, 1.0, "soft start: the oscillation amplitude grows smoothly from 0 to u0 over this time (needed with fibre_contact)"));
        let contact = FibreContactSettings::default();
        v.push(ParamSpec::flag("fibre_contact", false, "fibre-fibre contact: centrelines stay a diameter apart, with friction fibre_friction; fibres that can touch advance in lock step (off: fibres pass through one another, at no cost)"));
        v.push(ParamSpec::float("fibre_friction", "1", contact.friction, 0.0, 10.0, "μ_ff, Coulomb friction coefficient between fibres (with fibre_contact)"));
        v.push(ParamSpec::float("contact_interval", "s", contact.interval, 1e-7, 1.0, "Δt_c, longest time between two broad-phase searches for fibre contact candidates; shortened so that a node at the largest imposed speed travels at most 4 elements in it (output broad_phase_interval)"));
        v.push(ParamSpec::float("contact_step_factor", "1", contact.step_factor, 1e-3, 1.0, "with fibre_contact, the largest time step as a fraction of the stable step (time_step_factor where smaller): above 0.5-0.6 a contact normal tilted by the other fibre's slope makes the in-plane grid-scale mode unstable; 0.5 costs 1.1-1.4x the wall time of 0.8, and in 13 webs crossed 139 laid pairs against 218 and threw landed fibre in one against four; pipelines/studies/PHYSICAL_WEBS.md, \"The contact step\""));
        v.push(ParamSpec::flag("self_contact", contact.self_contact, "with fibre_contact, a fibre also rests on its own laid loops that are not yet frozen (off: it passes through them; its frozen stretch it always meets). Cuts the crossed pairs within fibres 6-60x, costs 1.0-1.6x; pipelines/studies/PHYSICAL_WEBS.md"));
        v
    }
    fn check(&self, p: &ParamSet) -> Result<(), InvalidParam> {
        let own = stage_params(p);
        // a flag that only acts with fibre contact would otherwise be silently ignored
        if own.self_contact && !own.fibre_contact {
            return Err(InvalidParam::new("self_contact".into(), "self_contact: true needs fibre_contact: true (a fibre can only rest on its own loops when fibres touch at all)".into()));
        }
        LaidWebParams::from(own).validate()
    }
    fn cautions(&self, p: &ParamSet) -> Vec<ParamCaution> {
        let lw = laid_web_params(p);
        let scene = lw.stepped_scene(lw.scene.clone());
        crate::rod::scene::cautions(&scene, lw.resolved_element_length())
    }
    /// [`LaidWebParams::estimated_cpu_seconds`] of one web; with fibre contact what it
    /// costs at least (a dense web's contact work grows with its pile, which the
    /// estimate leaves out: README, performance).
    fn estimate_cpu_time(&self, p: &ParamSet) -> Option<crate::stages::CpuTime> {
        let lw = laid_web_params(p);
        Some(crate::stages::CpuTime {
            seconds: lw.estimated_cpu_seconds(),
            bound: if lw.fibre_contact.is_some() { crate::stages::Bound::AtLeast } else { crate::stages::Bound::About },
            advice: "lower belt_travel, fibres_across or replicates".into(),
        })
    }
    /// Every web of the run is held until the output is written
    /// (`KEPT_BYTES_PER_NODE`), and each thread simulates one fibre
    /// ([`SIM_BYTES_PER_NODE`], all its nodes active at worst); with fibre contact every
    /// fibre of a web is simulated at once, with its contact state
    /// (`CONTACT_BYTES_PER_NODE`).
    fn estimate_memory(&self, stage: &Declared) -> Option<Estimate> {
        let fibres = declared_fibres(stage);
        let nodes: f64 = fibres.iter().map(|f| f.count * f.nodes).sum();
        let longest = fibres.iter().map(|f| f.nodes).fold(0.0, f64::max);
        let count: f64 = fibres.iter().map(|f| f.count).sum();
        let params: Vec<LaidWebParams> = stage.points.iter().map(laid_web_params).collect();
        let simulated = params
            .iter()
            .map(|p| match p.fibre_contact {
                Some(_) => p.nodes_per_web() * (SIM_BYTES_PER_NODE + CONTACT_BYTES_PER_NODE),
                None => 0.0,
            })
            .fold(concurrent(count) * longest * SIM_BYTES_PER_NODE, f64::max);
        let bytes = nodes * KEPT_BYTES_PER_NODE + simulated;
        let what = format!("{count} fibres of up to {longest:.3e} nodes, {nodes:.3e} laid nodes in all kept until written, {KEPT_BYTES_PER_NODE} B each, and the fibres simulated at once");
        Some(Estimate::new(bytes, what, &stage.name, &["fibres_across", "belt_travel"]).falling_with(&stage.name, &["element_length"]))
    }
    fn run(&self, ctx: &RunContext) -> Result<Output> {
        crate::stages::run_by_units(self, ctx)
    }
    fn units(&self, ctx: &RunContext) -> Result<Option<Units>> {
        Ok(Some(Units { points: ctx.points.len(), per_point: ctx.replicates, note: None }))
    }
    fn run_units(&self, ctx: &RunContext, range: std::ops::Range<usize>) -> Result<Output> {
        let params: Vec<LaidWebParams> = ctx.points.iter().map(laid_web_params).collect();
        let reps = ctx.replicates;
        let fibres: u64 = range.clone().map(|u| params[u / reps].fibres_across as u64).sum();
        let bar = crate::progress::bar(ctx.progress, fibres, &format!("{} fibres", ctx.stage_name));
        let webs: Vec<(usize, usize, LaidWeb)> = range
            .map(|u| {
                let (p, r) = (u / reps, u % reps);
                (p, r, lay_web(&params[p], ctx.seed, r, &bar))
            })
            .collect();
        bar.finish_and_clear();
        // every unit's fibre axis is the widest point's, so rows computed apart (Slurm
        // tasks) stack without padding
        let fibres = params.iter().map(|p| p.fibres_across).max().unwrap_or(0);
        unit_rows(&webs, fibres)
    }
    fn reduce(&self, ctx: &RunContext, rows: Output) -> Result<Output> {
        let params: Vec<LaidWebParams> = ctx.points.iter().map(laid_web_params).collect();
        assemble(&params, ctx.replicates, &rows)
    }
}

/// Per-fibre scalar columns: (name, unit, label (the long_name), description, value).
type FibreColumn = (&'static str, &'static str, &'static str, &'static str, fn(&super::LaidFibre) -> f64);
const FIBRE_COLUMNS: &[FibreColumn] = &[
    ("radius_of_gyration", "m", "S", "S of the laid fibre as it lies on the belt (eq 5)", |f| f.radius_of_gyration),
    ("bending_energy", "1", "e", "e = V_b L / EI of the laid fibre as it lies on the belt (eq 6)", |f| f.bending_energy),
    ("radius_of_gyration_belt_removed", "m", "S, belt removed", "S with the belt motion removed: spread around the deposition point", |f| f.radius_of_gyration_belt_removed),
    ("bending_energy_belt_removed", "1", "e, belt removed", "e with the belt motion removed", |f| f.bending_energy_belt_removed),
    ("phase", "rad", "oscillation phase φ", "oscillation phase φ of the fibre, u0 sin(ωt + φ)", |f| f.phase),
    ("frequency_scale", "1", "relative oscillation frequency", "oscillation frequency of the fibre over oscillation_frequency (jitter)", |f| f.frequency_scale),
    ("amplitude_scale", "1", "relative oscillation amplitude", "oscillation amplitude of the fibre over oscillation_amplitude (jitter)", |f| f.amplitude_scale),
    ("feed_cd", "m", "feed point CD position", "CD position of the fibre's feed point", |f| f.feed_cd),
    ("laid_length", "m", "laid length", "arc length of the laid fibre", |f| f.fed.laid_nodes().saturating_sub(1) as f64 * f.fed.element_length),
    ("frozen_nodes", "1", "frozen nodes", "nodes frozen (stuck, carried with the belt at no cost) during the run", |f| f.fed.frozen_nodes as f64),
    ("final_lift_of_landed", "m", "highest landed node at the end", "highest landed node above the belt at the end", |f| f.fed.final_lift_of_landed),
    ("lifted_fraction", "1", "lifted share of the last period", "share of the fibre's last oscillation period in which a landed node stood above bounce_tolerance (bounce_check = last_period invalidates above 0.5; NaN with final)", |f| f.fed.lift_watch.map_or(f64::NAN, |w| w.lifted_fraction())),
    ("steps", "1", "time steps", "time steps", |f| f.fed.steps as f64),
    ("rollbacks", "1", "rollbacks", "times the fibre was rolled back to a checkpoint after a failed step and the stretch retaken with the recovery scheme (0: none; with fibre_contact every fibre that could touch the failed one goes back with it to the start of the broad-phase interval, and each counts it)", |f| f.fed.rollbacks as f64),
    ("node_steps", "1", "node steps", "sum over steps of the active nodes (the work done)", |f| f.fed.node_steps as f64),
    ("max_active_nodes", "1", "most active nodes", "most nodes integrated at once", |f| f.fed.max_active_nodes as f64),
    ("wall_seconds", "s", "wall time of the fibre", "wall time of the fibre's own steps (with fibre contact: its narrow phase included)", |f| f.fed.wall_seconds),
    ("contact_impulses", "1", "fibre contact impulses", "velocity impulses against other fibres (0 without fibre_contact)", |f| f.contact_impulses as f64),
    ("contact_corrections", "1", "fibre contact corrections", "position corrections against other fibres (0 without fibre_contact)", |f| f.contact_corrections as f64),
    ("crossed_pair_steps", "1", "crossed pair-steps", "pair-steps in which a pair was found closer than d/2 (crossed) and left alone (0 without fibre_contact)", |f| f.crossed_pair_steps as f64),
];

/// The per-web rows of `webs` ((point, replicate, web) in any order): the laid-node axis
/// is NaN-padded to the longest web, the fibre axis is `nf` wide (padded with −1, 0, NaN,
/// invalid).
fn unit_rows(webs: &[(usize, usize, LaidWeb)], nf: usize) -> Result<Output> {
    let n = webs.len();
    let nodes = webs.iter().map(|w| w.2.fibres.iter().map(|f| f.fed.laid_nodes()).sum::<usize>()).max().unwrap_or(0);
    let mut laid = crate::memory::try_array((n, nodes, 3), f64::NAN, "the webs' laid nodes")?;
    let mut landing = crate::memory::try_array((n, nodes), f64::NAN, "the webs' landing times")?;
    let mut x_removed = crate::memory::try_array((n, nodes), f64::NAN, "the webs' belt-removed x")?;
    let mut start = Array2::from_elem((n, nf), -1i64);
    let mut count = Array2::from_elem((n, nf), 0i64);
    let mut valid = Array2::from_elem((n, nf), false);
    let mut reasons = Array2::from_elem((n, nf), "no fibre".to_string());
    let mut columns: Vec<Array2<f64>> = FIBRE_COLUMNS.iter().map(|_| Array2::from_elem((n, nf), f64::NAN)).collect();
    for (u, (_, _, web)) in webs.iter().enumerate() {
        let mut k = 0;
        for (j, f) in web.fibres.iter().enumerate() {
            start[[u, j]] = k as i64;
            let mut removed = f.x_belt_removed.iter();
            for (x, &t) in f.fed.positions.iter().zip(&f.fed.landing_time) {
                if t.is_finite() {
                    x_removed[[u, k]] = *removed.next().expect("one belt-removed x per laid node");
                    laid[[u, k, 0]] = x[0];
                    laid[[u, k, 1]] = x[1] + f.feed_cd;
                    laid[[u, k, 2]] = x[2];
                    landing[[u, k]] = t;
                    k += 1;
                }
            }
            count[[u, j]] = k as i64 - start[[u, j]];
            valid[[u, j]] = f.valid;
            for (c, col) in FIBRE_COLUMNS.iter().enumerate() {
                columns[c][[u, j]] = (col.4)(f);
            }
        }
        for (j, f) in web.fibres.iter().enumerate() {
            reasons[[u, j]] = f.invalid_reason.clone().unwrap_or_default();
        }
    }
    let web_col = |f: &dyn Fn(&LaidWeb) -> f64| Array1::from_iter(webs.iter().map(|w| f(&w.2)));
    let mut out = Output::new();
    out.i64("unit_point", &[UNIT_DIM], Array1::from_iter(webs.iter().map(|w| w.0 as i64)), "1", "point of the row");
    out.i64("unit_replicate", &[UNIT_DIM], Array1::from_iter(webs.iter().map(|w| w.1 as i64)), "1", "replicate of the row");
    out.f64("laid_positions", &[UNIT_DIM, "laid_node", "xyz"], laid, "m", "");
    out.f64("landing_time", &[UNIT_DIM, "laid_node"], landing, "s", "");
    out.f64("laid_x_belt_removed", &[UNIT_DIM, "laid_node"], x_removed, "m", "");
    out.i64("fibre_node_start", &[UNIT_DIM, "fibre"], start, "1", "");
    out.i64("fibre_laid_nodes", &[UNIT_DIM, "fibre"], count, "1", "");
    out.flags("valid", &[UNIT_DIM, "fibre"], valid, "");
    out.strings_nd("invalid_reason", &[UNIT_DIM, "fibre"], reasons, "");
    for (c, col) in FIBRE_COLUMNS.iter().enumerate() {
        out.f64(col.0, &[UNIT_DIM, "fibre"], columns[c].clone(), col.1, "");
    }
    out.f64("interior_md_min", &[UNIT_DIM], web_col(&|w| w.interior_md[0]), "m", "");
    out.f64("interior_md_max", &[UNIT_DIM], web_col(&|w| w.interior_md[1]), "m", "");
    out.f64("spread", &[UNIT_DIM], web_col(&|w| w.spread), "m", "");
    out.f64("wall_seconds_web", &[UNIT_DIM], web_col(&|w| w.wall_seconds), "s", "");
    out.f64("wall_seconds_contact", &[UNIT_DIM], web_col(&|w| w.contact.map_or(0.0, |c| c.wall_seconds)), "s", "");
    out.f64("contact_lock_steps", &[UNIT_DIM], web_col(&|w| w.contact.map_or(0.0, |c| c.lock_steps as f64)), "1", "");
    out.f64("contact_candidate_pairs", &[UNIT_DIM], web_col(&|w| w.contact.map_or(0.0, |c| c.candidate_pairs as f64 / (c.preparations.max(1) as f64))), "1", "");
    out.f64("contact_clusters", &[UNIT_DIM], web_col(&|w| w.contact.map_or(0.0, |c| c.clusters as f64 / (c.preparations.max(1) as f64))), "1", "");
    Ok(out)
}

/// The stage output from the per-web rows of every (point, replicate).
fn assemble(params: &[LaidWebParams], reps: usize, rows: &Output) -> Result<Output> {
    let np = params.len();
    let index = get::index(rows)?;
    let expected: Vec<(usize, usize)> = (0..np).flat_map(|p| (0..reps).map(move |r| (p, r))).collect();
    let mut sorted = index.clone();
    sorted.sort();
    if sorted != expected {
        bail!("the per-web rows are not every (point, replicate) of {np} points × {reps} replicates");
    }
    let f = |name: &str| -> Result<ArrayD<f64>> { Ok(place(get::f64(rows, name)?, &index, np, reps, f64::NAN)) };
    let i = |name: &str, fill: i64| -> Result<ArrayD<i64>> { Ok(place(get::i64(rows, name)?, &index, np, reps, fill)) };
    let nf = get::u8(rows, "valid")?.shape()[1];
    let mut out = Output::new();
    out.strings("xyz", "xyz", vec!["x".into(), "y".into(), "z".into()], "axis").describe("axis: x machine direction (belt motion), y cross direction, z up");
    out.f64("laid_positions", &["point", "replicate", "laid_node", "xyz"], f("laid_positions")?, "m", "laid nodes").describe("landed nodes in belt coordinates at the end of the run, fibre after fibre (x from the feed point, y not folded onto the CD period)");
    out.f64("landing_time", &["point", "replicate", "laid_node"], f("landing_time")?, "s", "time each laid node first touched the belt");
    out.f64("laid_x_belt_removed", &["point", "replicate", "laid_node"], f("laid_x_belt_removed")?, "m", "laid node x, belt removed").describe("x of each laid node with the belt motion removed (by belt_removal; y as laid), as the belt-removed S and e are measured");
    out.i64("fibre_node_start", &["point", "replicate", "fibre"], i("fibre_node_start", -1)?, "1", "first laid node of the fibre").describe("index of the fibre's first node on the laid_node axis");
    out.i64("fibre_laid_nodes", &["point", "replicate", "fibre"], i("fibre_laid_nodes", 0)?, "1", "laid nodes of the fibre");
    let valid = place(get::u8(rows, "valid")?, &index, np, reps, 0).mapv(|v| v != 0);
    out.flags("valid", &["point", "replicate", "fibre"], valid.clone(), "fibre valid").describe("fibre completed and no landed node above bounce_tolerance at the end (bounce_check final) or for more than half its last oscillation period (last_period)");
    let reasons = place(get::strings_nd(rows, "invalid_reason")?, &index, np, reps, String::new());
    out.strings_nd("invalid_reason", &["point", "replicate", "fibre"], reasons, "why the fibre is invalid (empty: valid)");
    for col in FIBRE_COLUMNS {
        out.f64(col.0, &["point", "replicate", "fibre"], f(col.0)?, col.1, col.2).describe(col.3);
    }
    for (name, unit, long) in [
        ("radius_of_gyration_belt_removed", "m", "belt-removed S"),
        ("bending_energy", "1", "e"),
        ("bending_energy_belt_removed", "1", "belt-removed e"),
    ] {
        let v = f(name)?;
        let (mut means, mut stds) = (vec![], vec![]);
        for p in 0..np {
            let xs: Vec<f64> = (0..reps)
                .flat_map(|r| (0..nf).map(move |j| (r, j)))
                .filter(|&(r, j)| valid[[p, r, j]])
                .map(|(r, j)| v[[p, r, j]])
                .filter(|x| x.is_finite())
                .collect();
            let (m, s) = crate::stages::mean_std(&xs);
            means.push(m);
            stds.push(s);
        }
        out.f64(&format!("{name}_mean"), &["point"], Array1::from(means), unit, &format!("mean {long}")).describe(format!("mean over the valid fibres of every replicate of the {long}"));
        out.f64(&format!("{name}_std"), &["point"], Array1::from(stds), unit, &format!("std of {long}")).describe(format!("sample standard deviation over the valid fibres of the {long}"));
    }
    let valid_count = Array2::from_shape_fn((np, reps), |(p, r)| (0..nf).filter(|&j| valid[[p, r, j]]).count() as i64);
    out.i64("valid_fibres", &["point", "replicate"], valid_count, "1", "valid fibres of the web");
    out.f64("interior_md_min", &["point", "replicate"], f("interior_md_min")?, "m", "interior MD range, lower end").describe("lower end of the interior MD range: edge_margin_spreads × spread from the touchdown (x = 0)");
    out.f64("interior_md_max", &["point", "replicate"], f("interior_md_max")?, "m", "interior MD range, upper end").describe("upper end of the interior MD range: v_b (T − t_s) − edge_margin_spreads × spread, t_s the start-up time");
    out.f64("spread", &["point", "replicate"], f("spread")?, "m", "RMS belt-removed S of valid fibres").describe("RMS belt-removed radius of gyration of the valid fibres");
    out.f64("wall_seconds_web", &["point", "replicate"], f("wall_seconds_web")?, "s", "wall time of the web").describe("wall time of the whole web (all its fibres, contact included), not of the output");
    out.f64("wall_seconds_contact", &["point", "replicate"], f("wall_seconds_contact")?, "s", "wall time of the contact broad phase").describe("wall time of the fibre contact's freezing, broad phase and clustering, outside the fibres' own steps and refreshes (0 without fibre_contact)");
    out.f64("contact_lock_steps", &["point", "replicate"], f("contact_lock_steps")?, "1", "lock steps").describe("sum over the clusters of fibres that can touch of the steps each took in lock step (0 without fibre_contact)");
    out.f64("contact_clusters", &["point", "replicate"], f("contact_clusters")?, "1", "clusters per search").describe("mean over the broad-phase searches of the clusters of fibres that can touch, each stepped on its own (0 without fibre_contact)");
    out.f64("contact_candidate_pairs", &["point", "replicate"], f("contact_candidate_pairs")?, "1", "candidate pairs per search").describe("mean over the broad-phase searches of the candidate (own segment, obstacle) pairs (0 without fibre_contact)");
    let per_point = |g: &dyn Fn(&LaidWebParams) -> f64| Array1::from_iter(params.iter().map(g));
    out.f64("cd_period", &["point"], per_point(&|p| p.cd_period()), "m", "CD period n_w·Δw of the web");
    out.f64("element_length", &["point"], per_point(&|p| p.resolved_element_length()), "m", "Δs, element length used (after coil_resolution)");
    out.f64("mass_per_length", &["point"], per_point(&|p| p.scene.mass_per_length()), "kg m-1", "ρπd²/4");
    out.f64("feed_time", &["point"], per_point(&|p| p.feed_time()), "s", "T = belt_travel/belt_speed");
    out.f64("broad_phase_interval", &["point"], per_point(&|p| p.fibre_contact.as_ref().map_or(0.0, |c| p.broad_phase_interval(c))), "s", "Δt_c used")
        .describe("time between two broad-phase searches for contact candidates: contact_interval, shortened so that a node at the largest imposed speed (v_f, v_b, ω u0) travels at most 4 elements in it (0 without fibre_contact)");
    out.f64("startup_time", &["point"], per_point(&|p| p.startup_time()), "s", "start-up time").describe("t_s = 2 z_f/v_f + 1/f, the start-up excluded from the interior");
    out.f64("belt_speed", &["point"], per_point(&|p| p.scene.belt_speed), "m s-1", "v_b, belt speed");
    out.f64("belt_speed_ratio", &["point"], per_point(&|p| p.belt_speed_ratio()), "1", "c = v_b/v_f");
    out.f64("expected_interior_density", &["point"], per_point(&|p| p.interior_areal_density() * 1e3), "g m-2", "expected interior areal density").describe("ρ(πd²/4)/(Δw·c), the interior areal density mass conservation implies");
    Ok(out)
}
