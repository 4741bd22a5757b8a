//! One fibre fed onto the belt by the laid-web machinery beside the same scene laid by
//! the laydown stage's simulator, replicate by replicate: S and e (raw and belt removed),
//! validity, and the feed's cost (laid, frozen and active nodes, steps, wall time).
//! A tool for checking the continuous feed against the single-fibre scene by eye; the
//! statistical comparison is the test `single_fibre_reproduces_laydown_statistics`.
//!
//! `cargo run --release --example laid_web_single -- [replicates seed] [name=value ...]`
//! with `name` a laydown scene parameter (`diameter=3e-5`, `oscillation_amplitude=0.02`,
//! `belt_speed=0.5`, …), `duration=` (s, default the scene's), `freeze=0|1`.
use laydown::rod::{replicate_rng, simulate, LaydownParams};
use laydown::stages::laid_web::{lay_web, LaidWebParams};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num: Vec<&String> = args.iter().filter(|a| !a.contains('=')).collect();
    let reps: usize = num.first().map_or(3, |s| s.parse().expect("replicates: a whole number"));
    let seed: u64 = num.get(1).map_or(7, |s| s.parse().expect("seed: a whole number"));
    // The quickstart-sized scene: L = 0.3 m fed at 5 m/s, 1 mm elements.
    let mut scene = LaydownParams { length: 0.3, elements: 300, ..LaydownParams::default() };
    let (mut duration, mut freeze) = (None, true);
    for kv in args.iter().filter(|a| a.contains('=')) {
        let (k, v) = kv.split_once('=').unwrap();
        match k {
            "duration" => duration = Some(v.parse::<f64>().expect("duration: seconds")),
            "freeze" => freeze = v != "0",
            _ => scene.set(k, v.parse().expect("a number")).unwrap_or_else(|e| panic!("{e}")),
        }
    }
    let duration = duration.unwrap_or(scene.end_time());
    let mut p = LaidWebParams { scene: scene.clone(), fibres_across: 1, belt_travel: scene.belt_speed * duration, element_length: 1e-3, ..LaidWebParams::default() };
    p.feed.freeze = freeze;
    for r in 0..reps {
        let w = lay_web(&p, seed, r, &indicatif::ProgressBar::hidden());
        let f = &w.fibres[0];
        println!(
            "replicate {r}: laid web: S {:.2} mm e {:.0} S_br {:.2} mm e_br {:.0} valid {} laid {} frozen {} steps {} node_steps {} max_active {} wall {:.2} s {:?}",
            f.radius_of_gyration * 1e3,
            f.bending_energy,
            f.radius_of_gyration_belt_removed * 1e3,
            f.bending_energy_belt_removed,
            f.valid,
            f.fed.laid_nodes(),
            f.fed.frozen_nodes,
            f.fed.steps,
            f.fed.node_steps,
            f.fed.max_active_nodes,
            f.fed.wall_seconds,
            f.invalid_reason
        );
        let l = simulate(&scene, &mut replicate_rng(seed, r as u64));
        println!(
            "             laydown: S {:.2} mm e {:.0} S_br {:.2} mm e_br {:.0} valid {} wall {:.2} s",
            l.radius_of_gyration * 1e3,
            l.bending_energy,
            l.radius_of_gyration_belt_removed * 1e3,
            l.bending_energy_belt_removed,
            l.valid,
            l.wall_seconds
        );
    }
}
