//! The laid web's run-time estimate (`LaidWebParams::estimated_node_steps`,
//! `estimated_cpu_seconds`, printed by `laydown validate`) against measured webs, on one
//! thread: node-steps done and estimated, wall time per node-step, CPU time estimated.
//! Used to set the constants in `src/stages/laid_web/mod.rs` (`CPU_SECONDS_PER_NODE_STEP`,
//! `SETTLING_DELAY`, `CONTACT_COST_SCALE`); the table is in the README ("Run time").
//!
//! `cargo run --release --example run_time_estimate -- [part of a case name]`; with the
//! environment variable `ESTIMATE_ONLY` set it prints the estimates without running.
use laydown::stages::laid_web::{lay_web, FibreContactSettings, LaidWebParams};
use laydown::rod::LaydownParams;
fn main() {
    let mut cases: Vec<(&str, LaidWebParams)> = Vec::new();
    let t1 = LaydownParams::default();
    let mut p = LaidWebParams { scene: t1.clone(), fibres_across: 4, fibre_spacing: 2e-3, belt_travel: 0.05, ..LaidWebParams::default() };
    cases.push(("table1 4x2mm 50mm", p.clone()));
    p.belt_travel = 0.02; p.feed.freeze = false;
    cases.push(("table1 4x2mm 20mm nofreeze", p.clone()));
    let mut s4 = t1.clone(); s4.diameter = 16.2e-6; s4.belt_speed = 0.25;
    cases.push(("table4 8x0.23mm 60mm", LaidWebParams { scene: s4.clone(), fibres_across: 8, fibre_spacing: 2.3036e-4, belt_travel: 0.06, ..LaidWebParams::default() }));
    let mut f50 = t1.clone(); f50.fibre_speed = 50.0; f50.air_speed = 150.0; f50.belt_speed = 2.0; f50.oscillation_frequency = 100.0;
    cases.push(("50 m/s 2x2mm 50mm", LaidWebParams { scene: f50, fibres_across: 2, fibre_spacing: 2e-3, belt_travel: 0.05, ..LaidWebParams::default() }));
    let mut c = LaidWebParams { scene: t1.clone(), fibres_across: 4, fibre_spacing: 8e-3, belt_travel: 0.04, fibre_contact: Some(FibreContactSettings::default()), ..LaidWebParams::default() };
    c.feed.oscillation_ramp = 0.01;
    cases.push(("contact table1 4x8mm 40mm", c.clone()));
    c.belt_travel = 0.02; c.fibre_spacing = 2e-3;
    cases.push(("contact table1 4x2mm 20mm", c.clone()));
    let mut c4 = LaidWebParams { scene: s4, fibres_across: 4, fibre_spacing: 2.3036e-4, belt_travel: 0.012, fibre_contact: Some(FibreContactSettings::default()), ..LaidWebParams::default() };
    c4.feed.oscillation_ramp = 0.01;
    cases.push(("contact table4 4 fibres 12mm", c4.clone()));
    // long enough for the freezing front to act (it needs the zone plus the margin of belt)
    c4.belt_travel = 0.04;
    cases.push(("contact table4 4 fibres 40mm", c4));
    c.belt_travel = 0.1; c.fibre_spacing = 8e-3;
    cases.push(("contact table1 4x8mm 100mm", c.clone()));
    let only: Option<String> = std::env::args().nth(1);
    for (name, p) in cases {
        if let Some(o) = &only { if !name.contains(o.as_str()) { continue; } }
        if std::env::var_os("ESTIMATE_ONLY").is_some() {
            println!("{name}: estimated node-steps {:.3e}, cpu {:.1} s", p.estimated_node_steps(), p.estimated_cpu_seconds());
            continue;
        }
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let clock = std::time::Instant::now();
        let web = pool.install(|| lay_web(&p, 7, 0, &indicatif::ProgressBar::hidden()));
        let wall = clock.elapsed().as_secs_f64();
        let ns: u64 = web.fibres.iter().map(|f| f.fed.node_steps).sum();
        let steps: u64 = web.fibres.iter().map(|f| f.fed.steps).sum();
        let est = p.estimated_node_steps();
        println!("{name}: node-steps {ns:.3e} estimated {est:.3e} (ratio {:.2}); steps {steps}; wall 1 thread {wall:.1} s = {:.3e} s per node-step; estimated cpu {:.1} s", est / ns as f64, wall / ns as f64, p.estimated_cpu_seconds());
    }
}
