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

/// n_w = 1 fed for the duration of the laydown scene is the laydown scene with a short
/// buffer above z0 instead of the long vertical fibre: at the Table 1 baseline its S and
/// e distributions agree with the laydown stage's (different imperfection draws and a
/// random oscillation phase, so within statistical error; 24 replicates: S belt removed
/// −0.4 %, z = 0.5; e −2.3 %, z = 1.9). On the quickstart-sized 0.3 m fibre they do not:
/// there the start-up, laid differently by the two starts, is a large share of the laid
/// fibre (48 replicates: S belt removed +11 %, e −10 %, z = 4.9-6.4; this test used that scene
/// with 8 replicates until 2026-12-06 and did not see it).
#[test]
fn single_fibre_reproduces_laydown_statistics() {
    let scene = LaydownParams::default();
    let p = laid_web_for(&scene, scene.end_time(), 1);
    let n = 16;
    let (mut s_web, mut e_web, mut s_lay, mut e_lay) = (vec![], vec![], vec![], vec![]);
    for r in 0..n {
        let f = &lay_web(&p, 11, r, &indicatif::ProgressBar::hidden()).fibres[0];
        assert!(f.valid, "{:?}", f.invalid_reason);
        s_web.push(f.radius_of_gyration_belt_removed);
        e_web.push(f.bending_energy);
        let l = simulate(&scene, &mut replicate_rng(11, r as u64));
        assert!(l.valid, "{:?}", l.invalid_reason);
        s_lay.push(l.radius_of_gyration_belt_removed);
        e_lay.push(l.bending_energy);
    }
    for (name, a, b) in [("S belt removed", &s_web, &s_lay), ("e", &e_web, &e_lay)] {
        let ((ma, sa), (mb, sb)) = (mean_se(a), mean_se(b));
        let z = (ma - mb).abs() / (sa * sa + sb * sb).sqrt();
        println!("{name}: laid_web {ma:.4e} ± {sa:.1e}, laydown {mb:.4e} ± {sb:.1e}, z = {z:.2}");
        assert!(z < 3.0, "{name}: laid_web {ma} ± {sa} against laydown {mb} ± {sb}");
        assert!((ma / mb - 1.0).abs() < 0.1, "{name}: {ma} against {mb}");
    }
}

/// Freezing stuck nodes changes S and e only by round-off-level amounts (frozen nodes
/// carry no force the active rod feels beyond the clamped end) and saves work.
#[test]
fn freezing_keeps_shape_and_saves_work() {
    let scene = small_scene();
    let mut p = laid_web_for(&scene, 0.4, 1);
    let frozen = lay_web(&p, 5, 0, &indicatif::ProgressBar::hidden()).fibres.remove(0);
    p.feed.freeze = false;
    let all = lay_web(&p, 5, 0, &indicatif::ProgressBar::hidden()).fibres.remove(0);
    assert!(frozen.valid && all.valid);
    assert!(frozen.fed.frozen_nodes > 500, "{}", frozen.fed.frozen_nodes);
    assert_eq!(all.fed.frozen_nodes, 0);
    assert_eq!(frozen.fed.laid_nodes(), all.fed.laid_nodes());
    // Freezing perturbs the creeping laid fibre slightly, and the coiling that follows
    // is chaotic: differences are those of a slightly different trajectory, bounded here
    // by 0.5 % in S and 1 % in e (the ensemble comparison is in accuracy_cost.yaml).
    for (name, a, b, tol) in [
        ("S belt removed", frozen.radius_of_gyration_belt_removed, all.radius_of_gyration_belt_removed, 5e-3),
        ("S", frozen.radius_of_gyration, all.radius_of_gyration, 5e-3),
        ("e", frozen.bending_energy, all.bending_energy, 1e-2),
    ] {
        println!("{name}: frozen {a:.6e}, all active {b:.6e}, {:+.3} %", 100.0 * (a / b - 1.0));
        assert!((a / b - 1.0).abs() < tol, "{name}: {a} against {b}");
    }
    let saved = all.fed.node_steps as f64 / frozen.fed.node_steps as f64;
    assert!(saved > 1.5, "node-steps without freezing / with: {saved}");
}

/// Without fibre contact the freezing front (`freeze_front_margin`) serves each fibre on
/// its own: at Table 1 a fibre's start-up end can slide on the belt for the whole run, and
/// since only a leading run of nodes freezes, the laid fibre behind it waited for the
/// 0.2 s age limit. With the front the web freezes sooner (a shorter largest active rod,
/// fewer node-steps; by the end the age limit has frozen about as much), and the shape
/// moves by what a slightly different trajectory gives (the 4-web ensemble of
/// `pipelines/studies/freezing_front.yaml`: S +0.10 %, e +0.24 %).
#[test]
fn freezing_front_serves_a_fibre_without_contact() {
    let scene = small_scene();
    let on = laid_web_for(&scene, 0.3, 2);
    assert_eq!(on.feed.front_margin, crate::rod::feed::FeedSettings::FRONT_MARGIN);
    let mut off = on.clone();
    off.feed.front_margin = 1.0;
    let (a, b) = (lay_web(&off, 2030, 0, &indicatif::ProgressBar::hidden()), lay_web(&on, 2030, 0, &indicatif::ProgressBar::hidden()));
    for (j, (fa, fb)) in a.fibres.iter().zip(&b.fibres).enumerate() {
        println!(
            "fibre {j}: frozen {} without the front, {} with; largest active rod {} against {}; node-steps {} against {}; S {:+.3} %, e {:+.3} %",
            fa.fed.frozen_nodes,
            fb.fed.frozen_nodes,
            fa.fed.max_active_nodes,
            fb.fed.max_active_nodes,
            fa.fed.node_steps,
            fb.fed.node_steps,
            100.0 * (fb.radius_of_gyration / fa.radius_of_gyration - 1.0),
            100.0 * (fb.bending_energy / fa.bending_energy - 1.0)
        );
        assert!(fa.valid && fb.valid, "{:?} {:?}", fa.invalid_reason, fb.invalid_reason);
        // by the end the age limit has frozen about as much (the last nodes of two runs
        // that part chaotically age at different times)
        assert!(fb.fed.frozen_nodes as f64 >= 0.98 * fa.fed.frozen_nodes as f64, "the front froze {} against {}", fb.fed.frozen_nodes, fa.fed.frozen_nodes);
        assert!((fb.fed.node_steps as f64) < 1.02 * fa.fed.node_steps as f64, "fibre {j}: the front cost work");
        assert!((fb.radius_of_gyration / fa.radius_of_gyration - 1.0).abs() < 5e-3);
        assert!((fb.bending_energy / fa.bending_energy - 1.0).abs() < 1e-2);
    }
    // the front froze the web sooner: a fibre whose laid part froze early without it gains
    // nothing (fibre 1 of this draw: node-steps −0.03 %, its largest active rod 517 nodes
    // both ways), one whose start-up end slid gains much (fibre 0: −41 %, 624 against
    // 1101). Seeds 2024-2039: the front saved 0-42 % of the node-steps, 10 % or more in 10
    // of the 16 (seed 2024, used here until 2026-12-06, saving about 1 % since the kick
    // became ½(Δt_prev + Δt))
    let cost = |w: &LaidWeb| (w.fibres.iter().map(|f| f.fed.node_steps).sum::<u64>(), w.fibres.iter().map(|f| f.fed.max_active_nodes).max().unwrap());
    let ((steps_a, largest_a), (steps_b, largest_b)) = (cost(&a), cost(&b));
    assert!((steps_b as f64) < 0.95 * steps_a as f64, "the front saved no work: {steps_b} node-steps against {steps_a}");
    assert!(largest_b < largest_a, "largest active rod {largest_b} against {largest_a}");
}

/// Every fed element is somewhere: laid, or still hanging. The laid length per belt
/// length in the interior is v_f/v_b (mass conservation along the belt).
#[test]
fn laid_length_per_belt_length_is_feed_over_belt_speed() {
    let scene = small_scene();
    // 1.2 s of laydown: the coils cut at the two ends of the window weigh half what they
    // do over 0.6 s (which read 25.55, 2.2 % high, on this seed)
    let p = laid_web_for(&scene, 1.2, 1);
    let web = lay_web(&p, 3, 0, &indicatif::ProgressBar::hidden());
    let f = &web.fibres[0];
    assert!(f.valid, "{:?}", f.invalid_reason);
    let ds = f.fed.element_length;
    let total = (f.fed.positions.len() - 1) as f64 * ds;
    let fed = p.feed_height() + scene.fibre_speed * f.fed.end_time;
    assert!((total - fed).abs() < 1.01 * ds, "fibre length {total} against fed {fed}");
    // over whole oscillation periods (v_b/f of belt each): within one period the fibre
    // lays its coils in bursts (±15 % in 10 mm bins at f = 10 Hz)
    let [a, b] = web.interior_md;
    let period = scene.belt_speed / scene.oscillation_frequency;
    let b = a + ((b - a) / period).floor() * period;
    assert!(b - a >= period, "interior {a}..{b} shorter than an oscillation period {period}");
    // nodes (segments) whose x lies in the interior, per metre of belt
    let inside = f.fed.positions.iter().zip(&f.fed.landing_time).filter(|(x, t)| t.is_finite() && x[0] >= a && x[0] < b).count();
    let ratio = inside as f64 * ds / (b - a);
    let expected = scene.fibre_speed / scene.belt_speed;
    println!("laid length per belt length {ratio} against v_f/v_b = {expected}");
    assert!((ratio / expected - 1.0).abs() < 0.02, "laid length per belt length {ratio} against v_f/v_b = {expected}");
}

/// Fibres are independent and own their random streams: any thread count gives the
/// same web, bit for bit. Independent turbulence gives each fibre its own phase,
/// coherent turbulence one phase for the row.
#[test]
fn web_is_identical_for_one_and_two_threads_and_turbulence_is_per_fibre() {
    let scene = small_scene();
    let mut p = laid_web_for(&scene, 0.06, 4);
    p.frequency_jitter = 0.1;
    let one = lay_web_on(1, &p, 9, 1);
    assert!(web_bits(&one) == web_bits(&lay_web_on(2, &p, 9, 1)), "1 and 2 threads differ");
    let phases: Vec<f64> = one.fibres.iter().map(|f| f.phase).collect();
    assert!(phases.windows(2).all(|w| w[0] != w[1]), "{phases:?}");
    assert!(one.fibres.iter().any(|f| f.frequency_scale != 1.0));
    p.turbulence = Turbulence::Coherent;
    let coherent = lay_web_on(2, &p, 9, 1);
    assert!(coherent.fibres.windows(2).all(|w| w[0].phase == w[1].phase && w[0].frequency_scale == w[1].frequency_scale));
}

/// Twist in a laid web (opt-in, feed clamped): fed segments enter the twist state
/// untwisted and frozen ones leave it (both exercised: the run freezes hundreds of
/// nodes), the web stays finite, twist changes it, and it is the same on 1 and 2 threads.
#[test]
fn twist_follows_the_feed_and_freezing() {
    let mut scene = small_scene();
    scene.effects.twist = true;
    let p = laid_web_for(&scene, 0.3, 2);
    let one = lay_web_on(1, &p, 4, 0);
    let two = lay_web_on(2, &p, 4, 0);
    let mut without = p.clone();
    without.scene.effects.twist = false;
    let plain = lay_web_on(2, &without, 4, 0);
    for ((a, b), c) in one.fibres.iter().zip(&two.fibres).zip(&plain.fibres) {
        assert!(a.fed.frozen_nodes > 100, "{} frozen", a.fed.frozen_nodes);
        assert!(a.fed.positions.iter().flatten().all(|x| x.is_finite()));
        assert_eq!(a.fed.positions, b.fed.positions, "1 and 2 threads differ");
        assert_ne!(a.fed.positions, c.fed.positions, "twist changed nothing");
    }
}

/// The stage's rows are [`stage::LaidWebStageParams`]'s fields but for the scene fields a
/// laid web sets itself ([`stage::NOT_FROM_LAYDOWN`]), which keep their defaults.
#[test]
fn stage_table_is_its_typed_parameters() {
    use crate::params::ParamSet;
    let table = crate::stages::Stage::params(&LaidWebStage);
    let d = LaidWebParams::default();
    let expected = stage::LaidWebStageParams {
        scene: LaydownParams::default(),
        fibres_across: d.fibres_across,
        fibre_spacing: d.fibre_spacing,
        belt_travel: d.belt_travel,
        element_length: d.element_length,
        turbulence: d.turbulence,
        frequency_jitter: d.frequency_jitter,
        amplitude_jitter: d.amplitude_jitter,
        edge_margin_spreads: d.edge_margin_spreads,
        freeze: d.feed.freeze,
        settle_time: d.feed.settle_time,
        freeze_front_margin: d.feed.front_margin,
        oscillation_ramp: d.feed.oscillation_ramp,
        fibre_contact: d.fibre_contact.is_some(),
        fibre_friction: FibreContactSettings::default().friction,
        contact_interval: FibreContactSettings::default().interval,
        self_contact: FibreContactSettings::default().self_contact,
        contact_step_factor: FibreContactSettings::default().step_factor,
    };
    let defaults = ParamSet::defaults(&table);
    assert_eq!(defaults.to_typed::<stage::LaidWebStageParams>().unwrap(), expected);
    let mut rows = ParamSet::from_typed(&expected).unwrap();
    rows.0.retain(|name, _| !stage::NOT_FROM_LAYDOWN.contains(&name.as_str()));
    assert_eq!(rows, defaults);
    assert_eq!(stage::laid_web_params(&defaults), LaidWebParams { scene: LaydownParams::default(), ..d });
}

/// Replicate `replicate` of web `p` with `seed`, on `threads` threads.
fn lay_web_on(threads: usize, p: &LaidWebParams, seed: u64, replicate: usize) -> LaidWeb {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| lay_web(p, seed, replicate, &indicatif::ProgressBar::hidden()))
}

/// Every bit of a web but its wall times (Debug prints every float exactly, NaN included).
fn web_bits(w: &LaidWeb) -> String {
    let mut w = w.clone();
    w.fibres.iter_mut().for_each(|f| f.fed.wall_seconds = 0.0);
    w.wall_seconds = 0.0;
    w.contact.iter_mut().for_each(|c| c.wall_seconds = 0.0);
    format!("{w:?}")
}

/// Pairs of laid segments of one fibre, 3 or more apart along it, closer than d/2
/// (crossed): a fibre laid across its own loops.
fn self_crossed(web: &LaidWeb, d: f64) -> usize {
    use crate::rod::fibre_contact::laid_self_gaps;
    web.fibres.iter().map(|f| laid_self_gaps(&f.fed.positions, &f.fed.landing_time).filter(|&g| g < 0.5 * d).count()).sum()
}

/// The sparse web of the contact tests (Table 1 scene, 4 fibres 25 mm apart, 20 mm of
/// belt, no fibre contact yet).
fn sparse_web() -> (LaydownParams, LaidWebParams) {
    let scene = small_scene();
    let mut p = laid_web_for(&scene, 0.0, 4);
    p.belt_travel = 0.02;
    p.fibre_spacing = 0.025;
    p.feed.oscillation_ramp = 0.01;
    (scene, p)
}

/// `self_contact`: in the sparse web a fibre lands across its own loops that are not yet
/// frozen and, without it, goes through them (measured: 301
/// crossed pairs within fibres, against 5 with it); 1 and 2 threads give the same web.
#[test]
fn self_contact_keeps_fibres_off_their_own_loops_on_any_thread_count() {
    let (scene, mut p) = sparse_web();
    p.fibre_contact = Some(FibreContactSettings::default());
    let without = self_crossed(&lay_web_on(2, &p, 7, 0), scene.diameter);
    p.fibre_contact = Some(FibreContactSettings { self_contact: true, ..FibreContactSettings::default() });
    let one = lay_web_on(1, &p, 7, 0);
    let with = self_crossed(&one, scene.diameter);
    println!("crossed pairs within fibres: {with} with self_contact, {without} without");
    assert!(without > 50, "without self_contact only {without} pairs crossed: the test shows nothing");
    assert!(10 * with <= without, "with self_contact {with} crossed pairs within fibres, without {without}");
    assert!(web_bits(&one) == web_bits(&lay_web_on(2, &p, 7, 0)), "1 and 2 threads differ");
    for f in &one.fibres {
        assert!(f.fed.error.is_none() && f.fed.positions.iter().flatten().all(|x| x.is_finite()), "{:?}", f.fed.error);
    }
}

/// Least centreline distance between laid segments (both ends landed) of different
/// fibres (nearest CD image), and the pairs closer than d/2 (crossed).
fn laid_pairs(fibres: &[LaidFibre], p: &LaidWebParams) -> (f64, usize) {
    use crate::rod::fibre_contact::closest_points;
    let (d, period) = (p.scene.diameter, p.cd_period());
    let segments: Vec<Vec<([f64; 3], [f64; 3])>> = fibres
        .iter()
        .map(|f| {
            let at = |i: usize| [f.fed.positions[i][0], f.fed.positions[i][1] + f.feed_cd, f.fed.positions[i][2]];
            let laid = |i: usize| f.fed.landing_time[i].is_finite();
            (0..f.fed.positions.len() - 1).filter(|&i| laid(i) && laid(i + 1)).map(|i| (at(i), at(i + 1))).collect()
        })
        .collect();
    let (mut least, mut crossed) = (f64::INFINITY, 0);
    for a in 0..segments.len() {
        for b in a + 1..segments.len() {
            for sa in &segments[a] {
                for sb in &segments[b] {
                    let dy = ((sa.0[1] - sb.0[1]) / period).round() * period;
                    let g = closest_points(sa.0, sa.1, [sb.0[0], sb.0[1] + dy, sb.0[2]], [sb.1[0], sb.1[1] + dy, sb.1[2]]).2;
                    let g = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                    least = least.min(g);
                    crossed += usize::from(g < 0.5 * d);
                }
            }
        }
    }
    (least / d, crossed)
}

/// A sparse web (Table 1 scene, 4 fibres 25 mm apart, 20 mm of belt) with fibre
/// contact: the fibres touch (impulses), no laid pair of different fibres ends closer
/// than 0.95 d or crossed, which without contact they do, and 1 and 2 threads give the
/// same web, bit for bit.
#[test]
fn contact_web_keeps_laid_fibres_apart_on_any_thread_count() {
    let (_, mut p) = sparse_web();
    let without = lay_web_on(2, &p, 7, 0);
    p.fibre_contact = Some(FibreContactSettings::default());
    let one = lay_web_on(1, &p, 7, 0);
    assert!(web_bits(&one) == web_bits(&lay_web_on(2, &p, 7, 0)), "1 and 2 threads differ");
    // the run-time estimate's work model against the work done, with and without contact
    for (web, p) in [(&without, &LaidWebParams { fibre_contact: None, ..p.clone() }), (&one, &p)] {
        let done: u64 = web.fibres.iter().map(|f| f.fed.node_steps).sum();
        let ratio = p.estimated_node_steps() / done as f64;
        println!("estimated node-steps / done: {ratio:.2} (contact {})", p.fibre_contact.is_some());
        assert!((0.5..2.0).contains(&ratio), "estimated node-steps {:.3e}, done {done}", p.estimated_node_steps());
    }
    let impulses: u64 = one.fibres.iter().map(|f| f.contact_impulses).sum();
    let (least, crossed) = laid_pairs(&one.fibres, &p);
    let (least_without, crossed_without) = laid_pairs(&without.fibres, &p);
    println!("contact: {impulses} impulses, least laid distance {least:.3} d, {crossed} crossed; without: {least_without:.3} d, {crossed_without} crossed");
    assert!(impulses > 0, "no contact happened");
    assert!(least >= 0.95 && crossed == 0, "least {least:.3} d, {crossed} crossed pairs");
    assert!(crossed_without > 0, "without contact no pair crossed: the test shows nothing");
    for f in &one.fibres {
        assert!(f.fed.error.is_none() && f.fed.positions.iter().flatten().all(|x| x.is_finite()), "{:?}", f.fed.error);
    }
}

/// Four fibres at the Table 4 density (d = 16.2 µm, Δw = 0.23 mm, c = 0.05) over 8 mm of
/// belt, with contact. A node pressed by two fibres from opposite sides was held along both
/// normals, left free only along the line across them, and the length projection slid it
/// along that line at tens of m/s: two of the four fibres failed at 27.3 ms ("unstable
/// step", 510 m/s) and landed fibre was knocked 2.4-3.1 mm up. A node already held (nearly)
/// along a normal is no longer held along it again: all four fibres stay valid, and most
/// crossings are still removed. 1 and 2 threads give the same web, bit for bit.
#[test]
fn dense_contact_web_keeps_every_fibre_valid() {
    let mut scene = crate::rod::LaydownParams::default();
    scene.diameter = 16.2e-6;
    scene.belt_speed = 0.25;
    let mut p = LaidWebParams { scene, fibres_across: 4, fibre_spacing: 2.3036e-4, belt_travel: 0.008, ..LaidWebParams::default() };
    p.feed.oscillation_ramp = 0.01;
    let without = lay_web(&p, 7, 0, &indicatif::ProgressBar::hidden());
    p.fibre_contact = Some(FibreContactSettings::default());
    let web = lay_web_on(2, &p, 7, 0);
    // the four rods form one cluster, stepped and searched for contacts in parallel
    assert!(web_bits(&web) == web_bits(&lay_web_on(1, &p, 7, 0)), "1 and 2 threads differ");
    let (least, crossed) = laid_pairs(&web.fibres, &p);
    let (_, crossed_without) = laid_pairs(&without.fibres, &p);
    let lift = web.fibres.iter().map(|f| f.fed.final_lift_of_landed).fold(0.0, f64::max);
    println!("dense web with contact: {crossed} crossed laid pairs (without contact {crossed_without}), least {least:.3} d, top lift {:.3} mm", 1e3 * lift);
    for (j, f) in web.fibres.iter().enumerate() {
        assert!(f.valid, "fibre {j}: {:?}", f.invalid_reason);
        // spans propped over crossings count as laid: the laid fibre has no gaps
        let laid: Vec<usize> = (0..f.fed.landing_time.len()).filter(|&i| f.fed.landing_time[i].is_finite()).collect();
        let (first, last) = (laid[0], laid[laid.len() - 1]);
        assert_eq!(laid.len(), last - first + 1, "fibre {j}: gaps in the laid nodes {first}..={last}");
    }
    assert!(lift < 1e-3, "a landed node ends {lift:.3e} m above the belt");
    assert!(20 * crossed < crossed_without, "contact left {crossed} of {crossed_without} crossed pairs");
}

/// A contact web of `fibres` fibres 8 mm apart (Table 1 scene, nothing frozen) whose feed
/// stopped at 60 ms ([`crate::rod::feed::FeedSettings::feed_stop`]), left alone to 120 ms:
/// the laid-node speeds relative to the belt (median, 90th percentile; m/s) while fed at 60
/// ms and at 120 ms, and the least distance (in d) and crossed pairs of its laid fibres.
fn contact_web_after_its_feed_stops(fibres: usize) -> ((f64, f64), (f64, f64), (f64, usize)) {
    use crate::rod::test_support::median_and_p90;
    let mut p = LaidWebParams { fibres_across: fibres, fibre_spacing: 0.008, belt_travel: 0.024, fibre_contact: Some(FibreContactSettings::default()), ..LaidWebParams::default() };
    p.feed.oscillation_ramp = 0.01;
    p.feed.freeze = false;
    p.feed.feed_stop = 0.06;
    let mut web = ContactWeb::new(&p, p.fibre_contact.as_ref().unwrap(), 7, 0);
    let speeds = |web: &ContactWeb| median_and_p90(web.feeders.iter().flat_map(|f| f.laid_speeds()).collect());
    let mut fed = (f64::NAN, f64::NAN);
    for k in 0..web.intervals() {
        let (_, t1) = web.run_interval(k);
        if fed.0.is_nan() && t1 >= p.feed.feed_stop {
            fed = speeds(&web);
        }
    }
    for f in &web.feeders {
        assert!(f.simulator().driven_top.is_none(), "the top is still driven");
        assert!(f.laid_speeds().len() > 300, "{} laid nodes: the web is not laid", f.laid_speeds().len());
    }
    let left_alone = speeds(&web);
    let laid: Vec<LaidFibre> = web.into_fibres().into_iter().enumerate().map(|(j, (feeder, scene, turbulence))| finish_fibre(&p, &scene, j, feeder.finish(), turbulence, [0; 3])).collect();
    (fed, left_alone, laid_pairs(&laid, &p))
}

/// A fibre alone in a contact world comes to rest once its feed stops. It meets no other
/// fibre, so this checks that the world's lock steps and predictions add no motion of their
/// own, the control for the two fibres below.
#[test]
fn one_fibre_in_a_contact_world_comes_to_rest_after_its_feed_stops() {
    let (_, (median, p90), _) = contact_web_after_its_feed_stops(1);
    println!("one fibre, 60 ms after the stop: laid-node speed median {median:.1e}, 90 % {p90:.1e} m/s");
    assert!(median < 1e-4 && p90 < 1e-3, "median {median} m/s, 90 % {p90} m/s");
}

/// The target for a contact web at rest (PHYSICAL_WEBS.md, "A contact web moves on after
/// its feed stops"): two fibres 8 mm apart, left alone for 60 ms after their feed stopped,
/// should come to rest as one fibre does, and without sinking through each other (no laid
/// pair closer than 0.95 d). Fails: their laid nodes keep a median 0.033 m/s relative to the
/// belt at 120 ms (90 % 0.13 m/s), 0.050 m/s while fed; the least laid distance is 0.963 d
/// (seeds 7-12 of this web: medians 0.023-0.043 m/s at 120 ms). Before the pairs that share
/// ½ were solved for both fibres with the belt, laid ones included (2026-12-07): 0.088 m/s
/// (90 % 0.30 m/s), 0.071 m/s while fed, and 0.933 d.
#[test]
#[ignore = "fails: a contact web of two simulated fibres does not come to rest"]
fn a_contact_web_comes_to_rest_after_its_feed_stops() {
    let ((fed, _), (median, p90), (least, crossed)) = contact_web_after_its_feed_stops(2);
    println!("two fibres: laid-node speed median {fed:.3} m/s while fed; 60 ms after the stop median {median:.1e}, 90 % {p90:.1e} m/s; least laid distance {least:.3} d, {crossed} crossed");
    assert!(median < 1e-3, "median {median} m/s, 90 % {p90} m/s");
    assert!(least >= 0.95 && crossed == 0, "least laid distance {least:.3} d, {crossed} crossed pairs");
}

/// Fibre contact needs the soft start of the oscillation, and a contact interval
/// within the run: both refused with the parameter named.
#[test]
fn contact_web_parameters_are_checked() {
    let mut p = LaidWebParams { fibre_contact: Some(FibreContactSettings::default()), ..LaidWebParams::default() };
    assert_eq!(p.validate().unwrap_err().key, "oscillation_ramp");
    p.feed.oscillation_ramp = 0.01;
    p.validate().unwrap();
    p.fibre_contact = Some(FibreContactSettings { interval: 10.0, ..FibreContactSettings::default() });
    assert_eq!(p.validate().unwrap_err().key, "contact_interval");
    for step_factor in [0.0, 1.5, f64::NAN] {
        p.fibre_contact = Some(FibreContactSettings { step_factor, ..FibreContactSettings::default() });
        assert_eq!(p.validate().unwrap_err().key, "contact_step_factor", "{step_factor}");
    }
}

/// With fibre contact every fibre steps at most `contact_step_factor` of its stable step
/// (the scene's `time_step_factor` where smaller): the step its feeder takes first.
#[test]
fn contact_web_steps_at_the_contact_step_factor() {
    let mut p = LaidWebParams { fibres_across: 2, belt_travel: 0.005, fibre_contact: Some(FibreContactSettings::default()), ..LaidWebParams::default() };
    p.feed.oscillation_ramp = 0.01;
    assert_eq!(p.scene.time_step_factor, 0.8);
    let first_steps = |p: &LaidWebParams| ContactWeb::new(p, p.fibre_contact.as_ref().unwrap(), 7, 0).feeders.iter().map(|f| f.next_step()).collect::<Vec<_>>();
    let capped = first_steps(&p);
    p.fibre_contact.as_mut().unwrap().step_factor = 1.0;
    let scene = first_steps(&p);
    for (c, s) in capped.iter().zip(&scene) {
        assert!((c / s - 0.5 / 0.8).abs() < 1e-12, "first step {c:.3e} s at the contact step factor against {s:.3e} s at the scene's");
    }
}

/// The broad-phase interval is the user's `contact_interval` at the paper's speeds, and
/// shortened for fast fibres so that a node at the largest imposed speed travels
/// `BROAD_PHASE_TRAVEL` elements in it (limit cases of the rule, and the imposed speed
/// being whichever of v_f, v_b and ω u0 is largest).
#[test]
fn broad_phase_interval_follows_the_fastest_imposed_speed() {
    use super::BROAD_PHASE_TRAVEL;
    let c = FibreContactSettings::default();
    let table1 = LaidWebParams::default();
    // Table 1: v_f = 5 m/s, Δs = 1 mm: 4 elements take 0.8 ms, longer than 0.2 ms
    assert_eq!(table1.broad_phase_interval(&c), c.interval);
    let mut fast = LaidWebParams::default();
    fast.scene.fibre_speed = 50.0;
    fast.scene.air_speed = 150.0;
    fast.scene.belt_speed = 2.0;
    fast.scene.oscillation_frequency = 100.0;
    let ds = fast.resolved_element_length();
    let expected = BROAD_PHASE_TRAVEL * ds / 50.0;
    assert!(expected < c.interval);
    assert!((fast.broad_phase_interval(&c) - expected).abs() <= 1e-12 * expected);
    // a user's interval shorter than the limit is kept
    let short = FibreContactSettings { interval: 0.5 * expected, ..c.clone() };
    assert_eq!(fast.broad_phase_interval(&short), 0.5 * expected);
    // the oscillation is the fastest imposed motion: ω u0 = 2π·1 kHz·10 mm = 63 m/s > v_f
    let mut swinging = LaidWebParams::default();
    swinging.scene.oscillation_frequency = 1000.0;
    let omega_u0 = swinging.scene.oscillation_speed();
    assert!(omega_u0 > swinging.scene.fibre_speed);
    let expected = BROAD_PHASE_TRAVEL * swinging.resolved_element_length() / omega_u0;
    assert!((swinging.broad_phase_interval(&c) - expected.min(c.interval)).abs() <= 1e-12 * expected);
    assert!(swinging.broad_phase_interval(&c) < c.interval);
}

use crate::rod::contact_world::ContactBody;

/// A fed fibre of a contact web whose state goes bad once: a NaN put into the velocity
/// of a hanging node at its first step at or after `fault_at` (s), so that every retake
/// of that step fails, down to the smallest. A rollback restores a time before the fault,
/// which then does not fire again.
struct Faulty {
    feeder: Feeder,
    fault_at: Option<f64>,
}

impl ContactBody for Faulty {
    fn simulator(&self) -> &crate::rod::integrator::Simulator {
        self.feeder.simulator()
    }
    fn simulator_mut(&mut self) -> &mut crate::rod::integrator::Simulator {
        self.feeder.simulator_mut()
    }
    fn next_step(&self) -> f64 {
        ContactBody::next_step(&self.feeder)
    }
    fn advance_to(&mut self, until: f64) {
        if let Some(t) = self.fault_at.filter(|&t| self.feeder.simulator().t >= t) {
            let sim = self.feeder.simulator_mut();
            let hanging = sim.rod.nodes() - 3;
            sim.rod.v[hanging][0] = f64::NAN;
            println!("fault planted at t = {:.5} s (asked for {t} s)", sim.t);
            self.fault_at = None;
        }
        self.feeder.advance_to(until)
    }
    fn running(&self) -> bool {
        ContactBody::running(&self.feeder)
    }
    fn before_step(&mut self) {
        self.feeder.before_step()
    }
    fn checkpoint(&mut self) {
        self.feeder.checkpoint()
    }
    fn can_roll_back(&self) -> bool {
        self.feeder.can_roll_back()
    }
    fn roll_back(&mut self, failed_at: f64) {
        self.feeder.roll_back(failed_at)
    }
    fn landing_reach(&mut self) -> f64 {
        self.feeder.landing_reach()
    }
    fn freeze(&mut self, frozen: &mut Vec<[f64; 3]>, landing_front: f64) {
        self.feeder.freeze(frozen, landing_front)
    }
}

/// Two fibres 4 mm apart with fibre contact (Table 1 scene, 10 mm of belt), `rollbacks`
/// allowed, fibre 0 meeting a fault at `fault_at` (s): each fibre fed to the end.
fn faulty_contact_web(rollbacks: usize, fault_at: Option<f64>) -> Vec<FedFibre> {
    let scene = LaydownParams { rollbacks, ..small_scene() };
    let mut p = laid_web_for(&scene, 0.0, 2);
    p.belt_travel = 0.01;
    p.fibre_spacing = 0.004;
    p.feed.oscillation_ramp = 0.01;
    p.fibre_contact = Some(FibreContactSettings::default());
    let web = ContactWeb::new(&p, p.fibre_contact.as_ref().unwrap(), 7, 0);
    let intervals = web.intervals();
    let ContactWeb { feeders, mut world, mut stats, interval, feed_time, .. } = web;
    let mut bodies: Vec<Faulty> = feeders.into_iter().enumerate().map(|(j, feeder)| Faulty { feeder, fault_at: fault_at.filter(|_| j == 0) }).collect();
    for k in 0..intervals {
        let (t0, t1) = (k as f64 * interval, ((k + 1) as f64 * interval).min(feed_time));
        world.run_interval(&mut bodies, t0, t1, &mut stats);
    }
    assert!(bodies.iter().all(|b| b.fault_at.is_none()), "the fault never fired");
    bodies.into_iter().map(|b| b.feeder.finish()).collect()
}

/// A fibre whose state goes bad in a contact web is no longer lost: the fibres it can
/// touch go back with it to the start of the broad-phase interval and retake it with the
/// recovery scheme (each counts the rollback), and both are laid. Without rollbacks the
/// fault ends the fibre, as before; a web without a failure is bit-identical with and
/// without them (the checkpoints only copy the state).
#[test]
fn a_contact_web_goes_back_together_when_a_fibre_fails() {
    let clean = faulty_contact_web(crate::rod::recovery::ROLLBACKS, None);
    let clean_without = faulty_contact_web(0, None);
    for (a, b) in clean.iter().zip(&clean_without) {
        assert!(a.error.is_none() && a.rollbacks == 0, "{:?}", a.error);
        assert_eq!((&a.positions, a.steps), (&b.positions, b.steps), "the checkpoints changed the web");
    }
    let lost = faulty_contact_web(0, Some(0.0301));
    let reason = lost[0].error.as_deref().expect("without rollbacks the fault ends the fibre");
    assert!(reason.contains("unstable step"), "{reason}");
    assert!(lost[0].end_time < 0.0302, "the fibre stops at the fault, t = {}", lost[0].end_time);
    assert!(lost[1].error.is_none(), "{:?}", lost[1].error);
    let saved = faulty_contact_web(crate::rod::recovery::ROLLBACKS, Some(0.0301));
    for (j, (f, c)) in saved.iter().zip(&clean).enumerate() {
        let laid = |f: &FedFibre| f.landing_time.iter().filter(|t| t.is_finite()).count() as f64;
        println!("fibre {j}: rollbacks {}, end {:.4} s, laid nodes {} against {} without the fault", f.rollbacks, f.end_time, laid(f), laid(c));
        assert!(f.error.is_none(), "fibre {j}: {:?}", f.error);
        assert!(f.positions.iter().flatten().all(|x| x.is_finite()));
        assert!((f.end_time - c.end_time).abs() < 1e-9);
        // both fibres went back: they could touch when the fault fired
        assert_eq!(f.rollbacks, 1, "fibre {j}");
        assert!((laid(f) / laid(c) - 1.0).abs() < 0.05, "fibre {j}: laid nodes {} against {}", laid(f), laid(c));
    }
}

/// A real failure, not a planted one: fibre 15 of a web of `table4_contact.yaml`'s c = 0.07
/// (stage `laid_c007`'s scene, seed 2008, replicate 0; found by laying fibres 0-34 of seeds
/// 2000-2059 for 20 ms without rollbacks, where 5 of the 2 100 fibres failed), fed as the
/// stage fed it until 2026-12-07: in elements of the fed length over a whole number of
/// them (`feed_fibre` on the fibre's scene, 0.58741 mm; the stage now feeds exactly the
/// resolved 0.58763 mm, [`LaidWebParams::resolved_element_length`]). It stops at
/// 4.2 ms with a node past the speed limit after its step collapsed to 2.3 ns. Checkpoints
/// are not taken while the step has collapsed (`recovery::COLLAPSED_STEP`), so a rollback
/// goes back to before the collapse, and with rollbacks the fibre is laid (whether a
/// checkpoint fell due inside this case's collapse was not checked, as it was for the
/// case recorded before). (The runs are chaotic: a change of the physics or the scheme
/// moves such failures elsewhere, as it moved the cases recorded before: fibre 5 of seed
/// 2032 when a repeated length projection began to keep its multipliers, fibre 34 of seed
/// 2037 when the kick became ½(Δt_prev + Δt); then the first assertion says so.)
#[test]
fn a_fibre_whose_step_collapsed_before_it_failed_is_rolled_back_to_before_the_collapse() {
    use crate::params::{ParamSet, ParamValue};
    use crate::stages::Stage;
    let given: std::collections::BTreeMap<String, ParamValue> = [
        ("diameter", ParamValue::Float(16.2e-6)),
        ("belt_speed", ParamValue::Float(0.35)),
        ("fibre_spacing", ParamValue::Float(0.00023310)),
        ("fibres_across", ParamValue::Int(35)),
        ("belt_travel", ParamValue::Float(0.075)),
        ("oscillation_ramp", ParamValue::Float(0.01)),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    let p = stage::laid_web_params(&ParamSet::resolve(&LaidWebStage.params(), &given));
    let fibre = |rollbacks: usize| {
        let (mut rng, turbulence, mut scene) = fibre_setup(&p, 2008, 0, 15);
        scene.rollbacks = rollbacks;
        crate::rod::feed::feed_fibre(&scene, turbulence.0, 0.02, &p.feed, &mut rng)
    };
    let lost = fibre(0);
    let reason = lost.error.as_deref().unwrap_or("");
    assert!(reason.contains("unstable step at t = 4.21168"), "the case no longer fails as recorded: {:?}", lost.error);
    let saved = fibre(crate::rod::recovery::ROLLBACKS);
    println!("rollbacks {}, steps {}, end {:.4} s, {:?}", saved.rollbacks, saved.steps, saved.end_time, saved.error);
    assert!(saved.error.is_none(), "{:?} after {} rollbacks", saved.error, saved.rollbacks);
    assert!(saved.rollbacks >= 1);
    assert!(saved.positions.iter().flatten().all(|c| c.is_finite()));
    assert!(saved.landing_time.iter().filter(|t| t.is_finite()).count() > 10);
}

/// `bounce_check: last_period` in a laid web: every fibre, with and without fibre
/// contact, watches the web's last oscillation period before the end of the feed, and its
/// verdict is the watched share; `transient` (a lift history frozen fibre does not keep)
/// and a feed shorter than a period of laid fibre are refused by name.
#[test]
fn a_laid_web_watches_each_fibres_last_period() {
    use crate::rod::BounceCheck;
    // 40 Hz: a 25 ms period within the 50 ms of laid fibre of a 60 ms feed
    let scene = LaydownParams { bounce_check: BounceCheck::LastPeriod, oscillation_frequency: 40.0, ..small_scene() };
    // frequency jitter: each fibre still watches the web's nominal period
    let mut p = LaidWebParams { fibre_spacing: 0.008, frequency_jitter: 0.1, ..laid_web_for(&scene, 0.06, 2) };
    p.feed.oscillation_ramp = 0.01;
    p.validate().unwrap();
    for contact in [None, Some(FibreContactSettings::default())] {
        p.fibre_contact = contact.clone();
        let web = lay_web(&p, 7, 0, &indicatif::ProgressBar::hidden());
        for (j, f) in web.fibres.iter().enumerate() {
            let watch = f.fed.lift_watch.expect("every fibre watched");
            println!("contact {}: fibre {j} watched {:.4} s, lifted share {:.3}", contact.is_some(), watch.watched(), watch.lifted_fraction());
            assert!((watch.from - (p.feed_time() - 0.025)).abs() < 1e-12, "window from {}", watch.from);
            assert!((watch.watched() - 0.025).abs() < 1e-9, "watched {}", watch.watched());
            assert_eq!(f.valid, !watch.bounced(), "fibre {j}: {:?}", f.invalid_reason);
        }
    }
    let short = LaidWebParams { belt_travel: p.scene.belt_speed * 0.03, ..p.clone() };
    let err = short.validate().unwrap_err();
    assert!(err.to_string().contains("bounce_check") && err.to_string().contains("lays fibre for about"), "{err}");
    let transient = LaidWebParams { scene: LaydownParams { bounce_check: BounceCheck::Transient, ..p.scene.clone() }, ..p.clone() };
    assert!(transient.validate().unwrap_err().to_string().contains("transient"));
}

/// Each fibre's state in bits: time, positions, velocities, frozen nodes.
fn feeder_bits(f: &Feeder) -> String {
    let sim = f.simulator();
    format!("{:?}", (sim.t, &sim.rod.x, &sim.rod.v, f.frozen()))
}

/// The element length does not depend on the belt travel, so the same web laid over a
/// longer travel is the shorter one, to the bit, up to the shorter one's end: without
/// contact to its feed time, with contact over the broad-phase intervals the shorter feed
/// completes.
#[test]
fn a_longer_web_begins_as_the_shorter_one() {
    let mut short = laid_web_for(&small_scene(), 0.0, 2);
    short.belt_travel = 0.0137;
    short.fibre_spacing = 0.004;
    short.feed.oscillation_ramp = 0.01;
    let long = LaidWebParams { belt_travel: 0.0201, ..short.clone() };
    assert_eq!(short.resolved_element_length(), 1e-3);
    assert_eq!(long.resolved_element_length(), 1e-3);
    let t1 = short.feed_time();
    for j in 0..2 {
        let fed = |p: &LaidWebParams| {
            let (mut rng, turbulence, scene) = fibre_setup(p, 7, 0, j);
            let mut f = web_feeder(p, &scene, turbulence.0, &mut rng);
            f.advance_to(t1);
            assert!(f.running() && f.laid_speeds().len() > 50, "fibre {j}: running {}, {} laid", f.running(), f.laid_speeds().len());
            feeder_bits(&f)
        };
        assert!(fed(&short) == fed(&long), "fibre {j} differs at the shorter web's end without contact");
    }
    let settings = FibreContactSettings::default();
    let full = (t1 / short.broad_phase_interval(&settings)).floor() as usize;
    let contact = |p: &LaidWebParams| {
        let p = LaidWebParams { fibre_contact: Some(settings.clone()), ..p.clone() };
        let mut web = ContactWeb::new(&p, &settings, 7, 0);
        for k in 0..full {
            web.run_interval(k);
        }
        assert!(web.feeders.iter().all(|f| f.running() && f.laid_speeds().len() > 50));
        web.feeders.iter().map(feeder_bits).collect::<Vec<_>>()
    };
    assert!(contact(&short) == contact(&long), "the contact webs differ after {full} intervals");
}
