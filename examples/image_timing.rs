//! Times the image analysis on the paper's image size (871×617 pixels).
//! `cargo run --release --example image_timing`
use laydown::stages::image::render::{random_fibre_web, render, BondPattern, RenderParams};
use laydown::stages::image::{analyze, ImageParams};
fn main() {
    let px = 297e-3 / 871.0;
    let web = random_fibre_web(617, 871, px, 20.0, 10e-3, 1e-3, Some(35.0), 71);
    let rp = RenderParams { bonds: Some(BondPattern { contrast: 0.3, ..Default::default() }), bits: 8, ..Default::default() };
    let img = render(&web, px, &rp).unwrap().grey;
    let truth = render(&web, px, &RenderParams { bits: 8, ..Default::default() }).unwrap().grey;
    let cv_truth = laydown::uniformity::coefficient_of_variation(truth.iter().copied());
    let p = ImageParams::default();
    // The method before issue 17 (no notch growth, no censoring correction, one period
    // of edge band), timed alternately in the same run for the cost ratio.
    let before = ImageParams { notch_growth: false, censoring_correction: false, edge_margin_periods: 1.0, ..Default::default() };
    let reps: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    let no_censoring = ImageParams { censoring_correction: false, ..Default::default() };
    let mut runs = [(Vec::new(), Vec::new(), None), (Vec::new(), Vec::new(), None), (Vec::new(), Vec::new(), None)];
    for _ in 0..reps {
        for (k, params) in [&p, &before, &no_censoring].into_iter().enumerate() {
            let t = std::time::Instant::now();
            let c = cpu_ms();
            let a = analyze(&img, px, params).unwrap();
            runs[k].0.push(t.elapsed().as_secs_f64() * 1e3);
            runs[k].1.push(cpu_ms() - c);
            runs[k].2 = Some(a);
        }
    }
    for (k, (times, cpu, last)) in runs.iter_mut().enumerate() {
        cpu.sort_by(|a, b| a.total_cmp(b));
        times.sort_by(|a, b| a.total_cmp(b));
        let a = last.take().unwrap();
        println!(
            "{} 871×617: wall min {:.1} ms, median {:.1} ms; CPU (all threads) min {:.1} ms, median {:.1} ms over {reps} runs; web's own CV {:.4}, cv_raw {:.4} cv_corr {:.4} compensated {:.4}, {} peaks, {} bins grown, {:.2} % of pixels restored, threads {}",
            ["default", "before issue 17", "default without censoring_correction"][k],
            times[0], times[reps / 2], cpu[0], cpu[reps / 2], cv_truth, a.cv_raw, a.cv_corr, a.cv_corr_compensated, a.peaks.len(), a.grown_bins, 100.0 * a.censored_fraction, rayon::current_num_threads()
        );
    }
    let med = |k: usize, f: fn(&(Vec<f64>, Vec<f64>, Option<laydown::stages::image::ImageAnalysis>)) -> &Vec<f64>| f(&runs[k])[reps / 2];
    println!("cost ratio default / before: wall {:.2}, CPU {:.2}", med(0, |r| &r.0) / med(1, |r| &r.0), med(0, |r| &r.1) / med(1, |r| &r.1));
    println!("cost ratio without censoring_correction / before: wall {:.2}, CPU {:.2}", med(2, |r| &r.0) / med(1, |r| &r.0), med(2, |r| &r.1) / med(1, |r| &r.1));
}

/// CPU time of the whole process (all threads), ms: unaffected by other users of the machine.
fn cpu_ms() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6
}
