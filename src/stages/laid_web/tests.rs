use super::*;
use crate::rod::{replicate_rng, simulate};

/// The quickstart-sized scene: L = 0.3 m fed at 5 m/s, 1 mm elements.
fn small_scene() -> LaydownParams {
    LaydownParams { length: 0.3, elements: 300, ..LaydownParams::default() }
}

fn laid_web_for(scene: &LaydownParams, duration: f64, fibres: usize) -> LaidWebParams {
    LaidWebParams {
        scene: scene.clone(),
        fibres_across: fibres,
        belt_travel: scene.belt_speed * duration,
        element_length: scene.length / scene.elements as f64,
        ..LaidWebParams::default()
    }
}

fn mean_se(v: &[f64]) -> (f64, f64) {
    let (m, s) = crate::stages::mean_std(v);
    (m, s / (v.len() as f64).sqrt())
}

#[test]
#[ignore]
fn smoke() {
    let scene = small_scene();
    let duration: f64 = std::env::var("DUR").ok().and_then(|s| s.parse().ok()).unwrap_or(scene.end_time());
    let mut p = laid_web_for(&scene, duration, 1);
    p.feed.freeze = std::env::var("FREEZE").map(|v| v != "0").unwrap_or(true);
    for r in 0..3 {
        let w = lay_web(&p, 7, r, &indicatif::ProgressBar::hidden());
        let f = &w.fibres[0];
        println!(
            "r {r}: S {:.2} mm e {:.0} S_br {:.2} mm e_br {:.0} valid {} laid {} frozen {} steps {} node_steps {} max_active {} wall {:.2}s {:?}",
            f.radius_of_gyration * 1e3, f.bending_energy, f.radius_of_gyration_belt_removed * 1e3, f.bending_energy_belt_removed,
            f.valid, f.fed.laid_nodes(), f.fed.frozen_nodes, f.fed.steps, f.fed.node_steps, f.fed.max_active_nodes, f.fed.wall_seconds, f.invalid_reason
        );
        let l = simulate(&scene, &mut replicate_rng(7, r as u64));
        println!("   laydown: S {:.2} mm e {:.0} S_br {:.2} e_br {:.0} valid {} wall {:.2}", l.radius_of_gyration * 1e3, l.bending_energy, l.radius_of_gyration_belt_removed * 1e3, l.bending_energy_belt_removed, l.valid, l.wall_seconds);
    }
}
