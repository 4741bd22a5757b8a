//! A small laid web fed with fibre-fibre contact (the rods of `src/rod/` in lock step under
//! [`ContactWorld`]), beside the same web without it: how close the laid fibres come to
//! one another, how many pairs have crossed, how high landed fibre ends above the belt,
//! whether the laid nodes still simulated have come to rest (their speed relative to the
//! belt by distance downstream), and the cost. A tool for finding where contact fails in denser webs (`laid_web` offers
//! contact as `fibre_contact: true`; `pipelines/studies/PHYSICAL_WEBS.md`, last section).
//!
//! `cargo run --release --example laid_web_contact -- [fibres spacing_mm travel_mm seed] [name=value ...]`
//! with `name` a laydown scene parameter, or `interval=` (s, contact preparation interval),
//! `ramp=` (s, oscillation soft start), `mu_ff=` (fibre friction), `contact=0|1`,
//! `self=1` (a fibre also meets its own laid loops that are not yet frozen: `self_contact`),
//! `step=` (`contact_step_factor`, the largest step with contact as a fraction of the stable one),
//! `coherent=1` (every fibre the same oscillation phase), `check=1`
//! (after every interval, the true least distance between fibres from their positions,
//! instead of what each rod saw in its own steps, and each landed node that rises above
//! 0.5 mm, or `LIFT_ABOVE` metres; with `LIFT_AFTER` set, only from that time (s) on,
//! and then after every interval each fibre's highest landed node, how many landed nodes stand above 1 mm and
//! its fastest landed node relative to the belt; with the environment variable
//! `LIFT_PROFILE` set, the heights of the fibre around a lifted node, L landed, S held by
//! a contact, R resting on a fibre). `integrator=` picks the
//! scene's integrator by name; with the environment variable `DUMP_LAID=k` every k-th laid
//! node still simulated of the first two fibres is printed at the end (height, velocity
//! relative to the belt, flags). With `DISP_WINDOW=s` it prints how far the laid nodes
//! moved relative to the belt over the last s seconds (creep, not only speed); it also
//! names, per fibre, simulated nodes far downstream that do not count as laid. `drag=0`
//! switches the air drag off; `age_limit=` (s) freezes laid nodes that old whatever they do;
//! `settle_time=` (s, the stage's `settle_time`, default 0.02) is how long a laid node must
//! stay put (creep below 1 % of an element), and the least time since it landed, before it
//! may freeze;
//! `front_margin=` (m) freezes laid nodes that far downstream of where any fibre has landed
//! (with `contact=0`, of where each fibre itself has landed, and only nodes on the belt).
//! `feed_stop=` (s) stops the feed then: each fibre is cut at the feed point and falls,
//! and nothing drives the web any more; `freeze=0` freezes no laid node (settled, old or
//! behind the front); `speeds=k` (with contact only) prints, every k contact intervals, the
//! speed of the laid nodes still simulated relative to the belt (median, 90th percentile,
//! largest), the highest of them, and how many nodes are neither on the belt nor resting
//! on laid fibre (hanging, or spans over crossings): with `feed_stop=` and `freeze=0`,
//! whether a web left alone comes to rest. With `TRACE=j:i,...` (contact only) it prints,
//! after every contact interval from `TRACE_AFTER` (s, default 0), the height and the
//! velocity relative to the belt of node i of fibre j, numbered from the fibre's start with
//! frozen nodes counted (with `freeze=0` the numbers `DUMP_LAID` prints): with `interval=`
//! about one step, how a node moves step by step.
use laydown::rod::contact_world::{ContactBody, ContactStats};
use laydown::rod::feed::Feeder;
use laydown::rod::fibre_contact::{closest_points, laid_self_gaps};
use laydown::rod::LaydownParams;
use laydown::stages::laid_web::{fibre_setup, web_feeder, ContactWeb, FibreContactSettings, LaidWebParams, Turbulence};
use std::time::Instant;

/// A segment's end points and whether it is frozen.
type Segment = ([f64; 3], [f64; 3], bool);

/// Every segment of fibre `j` at time `t` in world coordinates: frozen ones carried with the
/// belt, then the simulated ones.
fn segments(f: &Feeder, y0: f64, vb: f64, t: f64) -> Vec<Segment> {
    let mut x: Vec<([f64; 3], bool)> = f.frozen().iter().map(|(x, tf, _)| ([x[0] + vb * (t - tf), x[1] + y0, x[2]], true)).collect();
    x.extend(f.simulator().rod.x.iter().map(|x| ([x[0], x[1] + y0, x[2]], false)));
    x.windows(2).map(|w| (w[0].0, w[1].0, w[0].1 && w[1].1)).collect()
}

/// Centreline distance of two segments (nearest CD image of the second), if below d.
fn gap_between(sa: ([f64; 3], [f64; 3]), sb: ([f64; 3], [f64; 3]), period: f64, d: f64) -> Option<f64> {
    let dy = ((sa.0[1] - sb.0[1]) / period).round() * period;
    let q0 = [sb.0[0], sb.0[1] + dy, sb.0[2]];
    let q1 = [sb.1[0], sb.1[1] + dy, sb.1[2]];
    let out = |p0: f64, p1: f64, r0: f64, r1: f64| p0.min(p1) > r0.max(r1) + d || r0.min(r1) > p0.max(p1) + d;
    if out(sa.0[0], sa.1[0], q0[0], q1[0]) || out(sa.0[1], sa.1[1], q0[1], q1[1]) || out(sa.0[2], sa.1[2], q0[2], q1[2]) {
        return None;
    }
    let g = closest_points(sa.0, sa.1, q0, q1).2;
    Some((g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt())
}

/// Least centreline distance between segments of different fibres (nearest CD image),
/// leaving out pairs of two frozen segments and segments above `top`; with the pair (fibre, segment) of each side.
fn least_between(segs: &[Vec<Segment>], period: f64, d: f64, top: f64) -> (f64, (usize, usize), (usize, usize)) {
    let mut best = (f64::INFINITY, (0, 0), (0, 0));
    for a in 0..segs.len() {
        for b in a + 1..segs.len() {
            for (i, sa) in segs[a].iter().enumerate() {
                for (k, sb) in segs[b].iter().enumerate() {
                    if (sa.2 && sb.2) || sa.0[2].min(sa.1[2]) > top || sb.0[2].min(sb.1[2]) > top {
                        continue;
                    }
                    let Some(g) = gap_between((sa.0, sa.1), (sb.0, sb.1), period, d) else { continue };
                    if g < best.0 {
                        best = (g, (a, i), (b, k));
                    }
                }
            }
        }
    }
    best
}

/// The laid nodes still simulated (not frozen) at the end, in 2 mm bins of distance
/// downstream of the feed point: how many, the median speed relative to the belt and the
/// median height. A laid web at rest moves with the belt (speed 0) and freezes; one that
/// keeps moving far downstream stays simulated, and its cost grows with its length.
fn laid_but_active(feeders: &[Feeder], d: f64) -> String {
    const BIN: f64 = 2e-3;
    let mut bins: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for f in feeders {
        let sim = f.simulator();
        // the same laid nodes, in the same order, as `Feeder::laid_speeds`
        let laid = (0..sim.rod.nodes()).filter(|&i| sim.laid_time(i).is_finite());
        for (i, speed) in laid.zip(f.laid_speeds()) {
            let x = sim.rod.x[i];
            let b = (x[0] / BIN).floor().max(0.0) as usize;
            if bins.len() <= b {
                bins.resize(b + 1, (Vec::new(), Vec::new()));
            }
            bins[b].0.push(speed);
            bins[b].1.push(x[2] / d);
        }
    }
    let median = |mut a: Vec<f64>| {
        a.sort_by(f64::total_cmp);
        a.get(a.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let rows: Vec<String> = bins
        .into_iter()
        .enumerate()
        .filter(|(_, b)| !b.0.is_empty())
        .map(|(k, (speed, z))| format!("{}-{} mm: {} nodes, |v - v_b| {:.3} m/s, z {:.1} d", 2 * k, 2 * k + 2, speed.len(), median(speed), median(z)))
        .collect();
    format!("laid nodes still simulated, by distance downstream of the feed point (medians): {}", rows.join("; "))
}

/// The laid nodes still simulated at time `t`: how many, their speed relative to the belt
/// (median, 90th percentile, largest), the highest of them, and how many nodes are neither
/// on the belt nor resting on laid fibre (hanging, or spans over crossings).
fn speeds_line(feeders: &[Feeder], d: f64, t: f64) -> String {
    let mut speeds: Vec<f64> = feeders.iter().flat_map(Feeder::laid_speeds).collect();
    let (mut others, mut top) = (0, 0.0f64);
    for sim in feeders.iter().map(Feeder::simulator) {
        for i in 0..sim.rod.nodes() {
            if sim.laid_time(i).is_finite() {
                top = top.max(sim.rod.x[i][2]);
            } else {
                others += 1;
            }
        }
    }
    speeds.sort_by(f64::total_cmp);
    let q = |p: f64| speeds.get(((speeds.len() as f64 - 1.0) * p) as usize).copied().unwrap_or(f64::NAN);
    format!(
        "t {t:.4} s: {} laid nodes simulated, |v - v_b| median {:.4} / 90 % {:.4} / largest {:.3} m/s, highest {:.2} d; {others} nodes neither on the belt nor resting on laid fibre",
        speeds.len(),
        q(0.5),
        q(0.9),
        q(1.0),
        top / d
    )
}

/// Every `every`-th laid node still simulated of the first two fibres: position, height,
/// velocity relative to the belt, and its flags in the last step (L landed on the belt,
/// S held up by a contact, R resting on fibre, W on the web): which nodes move, and how.
fn dump_laid(feeders: &[Feeder], every: usize, belt_speed: f64, d: f64) {
    for (j, f) in feeders.iter().enumerate().take(2) {
        let sim = f.simulator();
        let c = sim.fibre_contact.as_ref();
        let flag = |v: Option<&Vec<bool>>, m: usize, on: &'static str| if v.and_then(|v| v.get(m).copied()).unwrap_or(false) { on } else { "-" };
        for i in (0..sim.rod.nodes()).filter(|&i| sim.laid_time(i).is_finite()).step_by(every.max(1)) {
            let (x, v) = (sim.rod.x[i], sim.rod.v[i]);
            println!(
                "fibre {j} node {i}: x {:.3} mm, z {:.2} d, v - v_b ({:+.3} {:+.3} {:+.3}) m/s {}{}{}{}",
                x[0] * 1e3,
                x[2] / d,
                v[0] - belt_speed,
                v[1],
                v[2],
                if sim.landing_time[i].is_finite() { "L" } else { "-" },
                flag(c.map(|c| &c.supported), i, "S"),
                flag(c.map(|c| &c.resting), i, "R"),
                flag(c.map(|c| &c.on_web), i, "W")
            );
        }
    }
}

/// Laid nodes still simulated, by index along their fibre (frozen ones counted): position
/// relative to the belt (x − v_b t, y, z) and position in the lab.
type LaidNodes = std::collections::HashMap<usize, ([f64; 3], [f64; 3])>;

fn laid_in_belt_frame(feeders: &[Feeder], belt_speed: f64, t: f64) -> Vec<LaidNodes> {
    feeders
        .iter()
        .map(|f| {
            let sim = f.simulator();
            let mut laid = Vec::new();
            sim.laid_times(&mut laid);
            let base = f.frozen().len();
            (0..sim.rod.nodes()).filter(|&i| laid[i].is_finite()).map(|i| (base + i, ([sim.rod.x[i][0] - belt_speed * t, sim.rod.x[i][1], sim.rod.x[i][2]], sim.rod.x[i]))).collect()
        })
        .collect()
}

/// How far the laid nodes simulated at both times moved relative to the belt between
/// them, in 4 mm bins of distance downstream: machine-direction displacement (10th,
/// 50th, 90th percentile; negative: upstream), horizontal and vertical distance (median,
/// 90th percentile, largest), in µm. A web at rest moves 0; a jitter in place moves
/// about its amplitude whatever the window; a creep grows with the window.
fn print_displacements(before: &[LaidNodes], after: &[LaidNodes], window: f64) {
    const BIN: f64 = 4e-3;
    // per bin: (dx, horizontal, vertical) in µm
    let mut bins: Vec<[Vec<f64>; 3]> = Vec::new();
    for (b, a) in before.iter().zip(after) {
        for (i, (now, lab)) in a {
            let Some((then, _)) = b.get(i) else { continue };
            let k = (lab[0] / BIN).floor().max(0.0) as usize;
            if bins.len() <= k {
                bins.resize(k + 1, Default::default());
            }
            let dx = now[0] - then[0];
            bins[k][0].push(1e6 * dx);
            bins[k][1].push(1e6 * dx.hypot(now[1] - then[1]));
            bins[k][2].push(1e6 * (now[2] - then[2]).abs());
        }
    }
    let q = |a: &mut Vec<f64>, p: f64| {
        a.sort_by(f64::total_cmp);
        a.get(((a.len() as f64 - 1.0) * p) as usize).copied().unwrap_or(f64::NAN)
    };
    for (k, [dx, h, z]) in bins.iter_mut().enumerate().filter(|(_, b)| !b[0].is_empty()) {
        println!(
            "moved over the last {:.0} ms, {}-{} mm downstream, {} laid nodes: MD {:.1} / {:.1} / {:.1} µm; horizontal {:.1} / {:.1} / {:.1} µm; vertical {:.1} / {:.1} / {:.1} µm",
            1e3 * window,
            4 * k,
            4 * k + 4,
            dx.len(),
            q(dx, 0.1),
            q(dx, 0.5),
            q(dx, 0.9),
            q(h, 0.5),
            q(h, 0.9),
            q(h, 1.0),
            q(z, 0.5),
            q(z, 0.9),
            q(z, 1.0)
        );
    }
}

/// Per fibre, the simulated nodes more than 5 mm downstream that do not count as laid
/// (a node there that never counts holds up the freezing of every node after it).
fn not_laid_downstream(feeders: &[Feeder], d: f64) {
    for (j, f) in feeders.iter().enumerate() {
        let sim = f.simulator();
        let mut laid = Vec::new();
        sim.laid_times(&mut laid);
        let unlaid: Vec<usize> = (0..sim.rod.nodes()).filter(|&i| sim.rod.x[i][0] > 5e-3 && !laid[i].is_finite()).collect();
        match unlaid.first() {
            Some(&i) => println!("fibre {j}: {} of {} simulated nodes more than 5 mm downstream are not laid, the first node {i} at z {:.2} d", unlaid.len(), sim.rod.nodes(), sim.rod.x[i][2] / d),
            None => println!("fibre {j}: every one of {} simulated nodes more than 5 mm downstream is laid", sim.rod.nodes()),
        }
    }
}

/// The nodes `TRACE=j:i,...` names, as (fibre, node); panics on a fibre out of range.
fn traced_nodes(fibres: usize) -> Vec<(usize, usize)> {
    let Ok(spec) = std::env::var("TRACE") else { return Vec::new() };
    spec.split(',')
        .map(str::trim)
        .filter(|item| !item.is_empty())
        .map(|item| {
            let (j, i) = item.split_once(':').expect("TRACE: fibre:node, comma separated");
            let (j, i): (usize, usize) = (j.parse().expect("TRACE: fibre"), i.parse().expect("TRACE: node"));
            assert!(j < fibres, "TRACE: fibre {j} of {fibres}");
            (j, i)
        })
        .collect()
}

/// One `TRACE` line: node `i` of fibre `j` (from the fibre's start, frozen nodes counted)
/// at time `t`, height in diameters, velocity relative to the belt (m/s); a node frozen or
/// not yet fed says so.
fn trace_line(f: &Feeder, j: usize, i: usize, d: f64, vb: f64, t: f64) -> String {
    let (frozen, rod) = (f.frozen().len(), &f.simulator().rod);
    if i < frozen {
        return format!("trace t {t:.7} s fibre {j} node {i}: frozen");
    }
    match (rod.x.get(i - frozen), rod.v.get(i - frozen)) {
        (Some(x), Some(v)) => format!("trace t {t:.7} s fibre {j} node {i}: z {:.4} d, v - v_b ({:+.4} {:+.4} {:+.4}) m/s", x[2] / d, v[0] - vb, v[1], v[2]),
        _ => format!("trace t {t:.7} s fibre {j} node {i}: not fed yet ({} fed)", frozen + rod.nodes()),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num: Vec<&String> = args.iter().filter(|a| !a.contains('=')).collect();
    let fibres: usize = num.first().map_or(4, |s| s.parse().expect("fibres"));
    let spacing: f64 = num.get(1).map_or(2.0, |s| s.parse().expect("spacing (mm)")) * 1e-3;
    let travel: f64 = num.get(2).map_or(10.0, |s| s.parse().expect("travel (mm)")) * 1e-3;
    let seed: u64 = num.get(3).map_or(7, |s| s.parse().expect("seed"));
    let mut scene = LaydownParams::default();
    let (mut interval, mut ramp, mut mu_ff, mut contact, mut check, mut coherent, mut self_contact) = (2e-4, 0.01, 0.3, true, false, false, false);
    let mut step_factor = laydown::rod::fibre_contact::CONTACT_STEP_FACTOR;
    let mut age_limit: Option<f64> = None;
    let mut front_margin: Option<f64> = None;
    let mut settle_time: Option<f64> = None;
    let mut feed_stop: Option<f64> = None;
    let mut freeze = true;
    let mut speeds_every = 0usize;
    for kv in args.iter().filter(|a| a.contains('=')) {
        let (k, v) = kv.split_once('=').unwrap();
        match k {
            "interval" => interval = v.parse().unwrap(),
            "ramp" => ramp = v.parse().unwrap(),
            "mu_ff" => mu_ff = v.parse().unwrap(),
            "contact" => contact = v != "0",
            "self" => self_contact = v != "0",
            "step" => step_factor = v.parse().unwrap(),
            "check" => check = v != "0",
            "coherent" => coherent = v != "0",
            "drag" => scene.effects.drag = v != "0",
            "age_limit" => age_limit = Some(v.parse().unwrap()),
            "front_margin" => front_margin = Some(v.parse().unwrap()),
            "settle_time" => settle_time = Some(v.parse().unwrap()),
            "feed_stop" => feed_stop = Some(v.parse().unwrap()),
            "freeze" => freeze = v != "0",
            "speeds" => speeds_every = v.parse().unwrap(),
            "integrator" => scene.integrator = serde_json::from_str(&format!("\"{v}\"")).expect("integrator"),
            _ => scene.set(k, v.parse().expect("a number")).unwrap_or_else(|e| panic!("{e}")),
        }
    }
    let settings = FibreContactSettings { friction: mu_ff, interval, self_contact, step_factor };
    let turbulence = if coherent { Turbulence::Coherent } else { Turbulence::Independent };
    let mut p = LaidWebParams { scene, fibres_across: fibres, fibre_spacing: spacing, belt_travel: travel, turbulence, fibre_contact: contact.then(|| settings.clone()), ..LaidWebParams::default() };
    p.feed.oscillation_ramp = ramp;
    if let Some(m) = front_margin {
        p.feed.front_margin = m;
    }
    if let Some(s) = settle_time {
        p.feed.settle_time = s;
    }
    if let Some(a) = age_limit {
        p.feed.age_limit = a;
    }
    if let Some(t) = feed_stop {
        p.feed.feed_stop = t;
    }
    p.feed.freeze = freeze;
    p.validate().unwrap_or_else(|e| panic!("{e}"));
    let t_end = p.feed_time();
    let d = p.scene.diameter;
    let clock = Instant::now();
    let mut stats = ContactStats::default();
    let mut worst = vec![0.0f64; fibres];
    let feeders: Vec<Feeder>;
    if contact {
        // the stage's own web: feeders, contact world, intervals
        let mut web = ContactWeb::new(&p, &settings, seed, 0);
        let n = web.intervals();
        let mut reported = 0;
        let mut true_reports = 0;
        let mut lift_reports = 0;
        let mut was_lifted = vec![std::collections::HashSet::new(); fibres];
        let lift_above: f64 = std::env::var("LIFT_ABOVE").ok().map_or(5e-4, |v| v.parse().unwrap());
        let heights_after: Option<f64> = std::env::var("LIFT_AFTER").ok().map(|v| v.parse().unwrap());
        let lift_after = heights_after.unwrap_or(0.0);
        let disp_window: f64 = std::env::var("DISP_WINDOW").ok().map_or(0.0, |v| v.parse().unwrap());
        let mut snapshot: Option<Vec<LaidNodes>> = None;
        let vb = p.scene.belt_speed;
        let traced = traced_nodes(fibres);
        let trace_after: f64 = if traced.is_empty() { 0.0 } else { std::env::var("TRACE_AFTER").ok().map_or(0.0, |v| v.parse().expect("TRACE_AFTER (s)")) };
        for k in 0..n {
            let (_, t1) = web.run_interval(k);
            if speeds_every > 0 && (k + 1) % speeds_every == 0 {
                println!("{}", speeds_line(&web.feeders, d, t1));
            }
            if t1 >= trace_after {
                for &(j, i) in &traced {
                    println!("{}", trace_line(&web.feeders[j], j, i, d, vb, t1));
                }
            }
            if disp_window > 0.0 && snapshot.is_none() && t1 >= t_end - disp_window {
                snapshot = Some(laid_in_belt_frame(&web.feeders, vb, t1));
            }
            if let (true, Some(before)) = (k + 1 == n, &snapshot) {
                print_displacements(before, &laid_in_belt_frame(&web.feeders, vb, t1), disp_window);
            }
            let (feeders, world, stats) = (&mut web.feeders, &web.world, &web.stats);
            // the true least distance at the end of the interval, from both rods' positions
            if check {
                let segs: Vec<_> = feeders.iter().enumerate().map(|(j, f)| segments(f, world.cd_offsets[j], p.scene.belt_speed, t1)).collect();
                let (g, (fa, sa), (fb, sb)) = least_between(&segs, p.cd_period(), d, world.contact_top);
                if g < 0.9 * d && true_reports < 100000 {
                    true_reports += 1;
                    let z = |f: usize, s: usize| (segs[f][s].0[2] / d, segs[f][s].1[2] / d, segs[f][s].2);
                    eprintln!("  TRUE t = {t1:.5} s: least {:.3} d between fibre {fa} segment {sa} {:?} and fibre {fb} segment {sb} {:?} (z/d, z/d, frozen)", g / d, z(fa, sa), z(fb, sb));
                }
            }
            // landed nodes that rise above 0.5 mm: where, how fast, and what is nearest
            if check && lift_reports < 40 && t1 >= lift_after {
                let segs: Vec<_> = feeders.iter().enumerate().map(|(j, f)| segments(f, world.cd_offsets[j], p.scene.belt_speed, t1)).collect();
                for (j, f) in feeders.iter().enumerate() {
                    let sim = f.simulator();
                    let base = f.frozen().len();
                    for (i, x) in sim.rod.x.iter().enumerate() {
                        let lifted = sim.landing_time[i].is_finite() && x[2] > lift_above;
                        if lifted && !was_lifted[j].contains(&(base + i)) && lift_reports < 40 {
                            lift_reports += 1;
                            let v = sim.rod.v[i];
                            let world_x = [x[0], x[1] + world.cd_offsets[j], x[2]];
                            // nearest segment of another fibre
                            let mut best = (f64::INFINITY, 0, 0);
                            for (k, other) in segs.iter().enumerate().filter(|(k, _)| *k != j) {
                                for (l, sg) in other.iter().enumerate() {
                                    let g = closest_points(world_x, world_x, sg.0, sg.1).2;
                                    let g = (g[0] * g[0] + g[1] * g[1]).sqrt().hypot(g[2]);
                                    if g < best.0 {
                                        best = (g, k, l);
                                    }
                                }
                            }
                            let (g, k, l) = best;
                            let o = &segs[k][l];
                            let hanging = feeders[k].simulator().landing_time.get(l.wrapping_sub(feeders[k].frozen().len())).is_none_or(|t| !t.is_finite());
                            eprintln!(
                                "  LIFT t = {t1:.4} s fibre {j} node {} (landed {:.4} s): z {:.2} mm, v ({:.2} {:.2} {:.2}) m/s; nearest other fibre {k} segment {l} at {:.2} d, z {:.3}/{:.3} mm, hanging {hanging}",
                                base + i, sim.landing_time[i], x[2] * 1e3, v[0], v[1], v[2], g / d, o.0[2] * 1e3, o.1[2] * 1e3
                            );
                            if std::env::var("LIFT_PROFILE").is_ok() {
                                // the fibre from 5 nodes before to 40 after: z (mm), landed, supported/resting in the last step
                                let c = sim.fibre_contact.as_ref();
                                let line: Vec<String> = (i.saturating_sub(5)..(i + 40).min(sim.rod.nodes()))
                                    .map(|m| {
                                        let flag = |v: Option<&Vec<bool>>| v.and_then(|v| v.get(m).copied()).unwrap_or(false);
                                        format!(
                                            "{m}:{:.2}{}{}{}",
                                            sim.rod.x[m][2] * 1e3,
                                            if sim.landing_time[m].is_finite() { "L" } else { "" },
                                            if flag(c.map(|c| &c.supported)) { "S" } else { "" },
                                            if flag(c.map(|c| &c.resting)) { "R" } else { "" }
                                        )
                                    })
                                    .collect();
                                eprintln!("    profile {}", line.join(" "));
                            }
                        }
                        if lifted {
                            was_lifted[j].insert(base + i);
                        }
                    }
                }
            }
            // intervals in which a pair came closer than 0.8 d (penetration reset each interval)
            for (j, f) in feeders.iter_mut().enumerate() {
                let frozen = f.frozen().len();
                let sim = f.simulator_mut();
                let landed = sim.landing_time.iter().filter(|t| t.is_finite()).count();
                let nodes = sim.rod.nodes();
                if let Some(c) = sim.fibre_contact.as_mut() {
                    if c.max_penetration > 0.2 * d && reported < 40 && !check {
                        reported += 1;
                        eprintln!(
                            "  t = {t1:.5} s fibre {j}: penetration {:.3} d, crossed pair-steps {}, impulses {}, corrections {}, nodes {nodes} (landed {landed}, frozen {frozen})",
                            c.max_penetration / d, c.crossed, c.impulses, c.corrections
                        );
                    }
                    if c.max_penetration > 0.2 * d && reported < 40 && !check {
                        // the closest candidate pair now
                        let mut best = (f64::INFINITY, 0usize, 0usize);
                        for r in 0..c.rows.len().saturating_sub(1) {
                            let k = r.wrapping_sub(c.dropped);
                            if k + 1 >= nodes {
                                continue;
                            }
                            for &q in &c.candidates[c.rows[r] as usize..c.rows[r + 1] as usize] {
                                let o = &c.obstacles[q as usize];
                                let tau = sim.t - o.t_ref;
                                let a = [o.a[0] + o.va[0] * tau, o.a[1] + o.va[1] * tau, o.a[2] + o.va[2] * tau];
                                let b = [o.b[0] + o.vb[0] * tau, o.b[1] + o.vb[1] * tau, o.b[2] + o.vb[2] * tau];
                                let g = closest_points(sim.rod.x[k], sim.rod.x[k + 1], a, b).2;
                                let g = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                                if g < best.0 {
                                    best = (g, k, q as usize);
                                }
                            }
                        }
                        if best.0.is_finite() {
                            let (g, k, q) = best;
                            let o = &c.obstacles[q];
                            let (x, v) = (sim.rod.x[k], sim.rod.v[k]);
                            eprintln!(
                                "    closest now {:.3} d: own segment {k} z {:.2}/{:.2} d v ({:.3} {:.3} {:.3}) landed {}; obstacle {:?} z {:.2}/{:.2} d landed {:?} simulated {} va ({:.3} {:.3} {:.3})",
                                g / d, x[2] / d, sim.rod.x[k + 1][2] / d, v[0], v[1], v[2], sim.landing_time[k].is_finite(),
                                o.source, o.a[2] / d, o.b[2] / d, o.landed, o.simulated, o.va[0], o.va[1], o.va[2]
                            );
                        }
                    }
                    worst[j] = worst[j].max(c.max_penetration);
                    c.max_penetration = 0.0;
                }
            }
            if check && heights_after.is_some_and(|a| t1 >= a) {
                // the highest landed node of each fibre and how many landed nodes are above 1 mm
                let tops: Vec<String> = feeders
                    .iter()
                    .map(|f| {
                        let sim = f.simulator();
                        let landed = sim.rod.x.iter().zip(&sim.landing_time).filter(|(_, t)| t.is_finite());
                        let (top, above) = landed.fold((0.0f64, 0), |(m, c), (x, _)| (m.max(x[2]), c + (x[2] > 1e-3) as usize));
                        let (vmax, imax) = sim.rod.v.iter().enumerate().filter(|(i, _)| sim.landing_time[*i].is_finite()).map(|(i, v)| (((v[0] - vb).powi(2) + v[1] * v[1] + v[2] * v[2]).sqrt(), i)).fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
                        format!("{:.2}/{above} v{vmax:.2}@{imax}/{}+{}", top * 1e3, sim.rod.nodes(), f.frozen().len())
                    })
                    .collect();
                eprintln!("HEIGHT t = {t1:.4} s: highest landed node (mm) / landed nodes above 1 mm, per fibre: {}", tops.join(" "));
            }
            if k % 50 == 0 {
                let pen = worst.iter().cloned().fold(0.0, f64::max);
                let running = feeders.iter().filter(|f| f.running()).count();
                eprintln!("t = {:.4} s: running {running}/{fibres}, max penetration so far {:.3} d, lock steps {}", t1, pen / d, stats.lock_steps);
            }
        }
        stats = web.stats;
        feeders = web.into_fibres().into_iter().map(|(f, _, _)| f).collect();
    } else {
        feeders = (0..fibres)
            .map(|j| {
                let (mut rng, turbulence, scene) = fibre_setup(&p, seed, 0, j);
                let mut f = web_feeder(&p, &scene, turbulence.0, &mut rng);
                f.advance_to(t_end);
                f
            })
            .collect();
    }
    let wall = clock.elapsed().as_secs_f64();
    let pen = worst;
    let (tests, skipped) = feeders.iter().filter_map(|f| f.simulator().fibre_contact.as_ref()).fold((0, 0), |(a, b), c| (a + c.pair_tests, b + c.pairs_skipped));
    eprintln!("narrow phase: {tests} pair tests, {skipped} skipped by the gap bound");
    println!("{}", laid_but_active(&feeders, d));
    not_laid_downstream(&feeders, d);
    if let Some(every) = std::env::var("DUMP_LAID").ok().and_then(|v| v.parse().ok()) {
        dump_laid(&feeders, every, p.scene.belt_speed, d);
    }
    let laid: Vec<_> = feeders.into_iter().map(|f| f.finish()).collect();
    // least distance between laid segments (both ends landed) of different fibres (world
    // coordinates, nearest CD image)
    let period = p.cd_period();
    let laid_segments: Vec<Vec<([f64; 3], [f64; 3])>> = laid
        .iter()
        .enumerate()
        .map(|(j, f)| {
            let y0 = (j as f64 + 0.5) * spacing - 0.5 * period;
            let at = |i: usize| [f.positions[i][0], f.positions[i][1] + y0, f.positions[i][2]];
            (0..f.positions.len().saturating_sub(1)).filter(|&i| f.landing_time[i].is_finite() && f.landing_time[i + 1].is_finite()).map(|i| (at(i), at(i + 1))).collect()
        })
        .collect();
    // the same within each fibre: laid segments three or more apart along it (a coil
    // laid across the fibre's own loops)
    let (mut self_crossed, mut self_close) = (0usize, 0usize);
    for g in laid.iter().flat_map(|f| laid_self_gaps(&f.positions, &f.landing_time)) {
        if g < 0.5 * d {
            self_crossed += 1;
        } else if g < 0.95 * d {
            self_close += 1;
        }
    }
    let (mut least, mut crossed, mut close) = (f64::INFINITY, 0usize, 0usize);
    for a in 0..laid_segments.len() {
        for b in a + 1..laid_segments.len() {
            for sa in &laid_segments[a] {
                for sb in &laid_segments[b] {
                    if let Some(g) = gap_between(*sa, *sb, period, d) {
                        least = least.min(g);
                        if g < 0.5 * d {
                            crossed += 1;
                        } else if g < 0.95 * d {
                            close += 1;
                        }
                    }
                }
            }
        }
    }
    let startup = p.startup_time();
    eprintln!("start-up time t_s = {startup:.4} s of {t_end:.4} s");
    // where the fibres landed along MD (x − v_b (t_end − t_laid): the belt's carry removed)
    let mut landed_at: Vec<f64> = laid
        .iter()
        .flat_map(|f| f.positions.iter().zip(&f.landing_time).filter(|(_, t)| t.is_finite() && **t > startup).map(|(x, t)| x[0] - p.scene.belt_speed * (t_end - t)))
        .collect();
    landed_at.sort_by(f64::total_cmp);
    if !landed_at.is_empty() {
        let q = |f: f64| landed_at[((landed_at.len() - 1) as f64 * f).round() as usize] * 1e3;
        println!("landing position along MD after the start-up (mm): min {:.1}, 1 % {:.1}, median {:.1}, 99 % {:.1}, max {:.1}", q(0.0), q(0.01), q(0.5), q(0.99), q(1.0));
    }
    if std::env::var_os("FIRST_ACTIVE").is_some() {
        for (j, f) in laid.iter().enumerate() {
            let a = f.frozen_nodes;
            let show: Vec<String> = (a..(a + 8).min(f.positions.len())).map(|i| format!("{:.1} mm/{:.3} s", f.positions[i][0] * 1e3, f.landing_time[i])).collect();
            println!("fibre {j}: first active nodes (x, laid): {}", show.join(", "));
        }
    }
    for (j, f) in laid.iter().enumerate() {
        println!(
            "fibre {j}: laid {} nodes, frozen {}, top lift {:.3} mm (node {} of {}, landed at {:.4} s; {} landed nodes above 1 mm, {} of them landed after the start-up), steps {} ({} rejected, smallest {:.2e} s, {} rollbacks), max penetration {:.3} d, error {:?}",
            f.laid_nodes(),
            f.frozen_nodes,
            f.final_lift_of_landed * 1e3,
            f.final_lift_node,
            f.positions.len(),
            f.landing_time[f.final_lift_node],
            f.positions.iter().zip(&f.landing_time).filter(|(x, t)| t.is_finite() && x[2] > 1e-3).count(),
            f.positions.iter().zip(&f.landing_time).filter(|(x, t)| t.is_finite() && **t > startup && x[2] > 1e-3).count(),
            f.steps,
            f.rejected_steps,
            f.min_time_step,
            f.rollbacks,
            pen[j] / d,
            f.error
        );
    }
    println!(
        "contact {contact}: wall {wall:.1} s, clusters per interval {:.2}, lock steps {}, broad phase {:.1} s, candidates per simulated segment {:.1}; laid pairs of segments of different fibres: least distance {:.3} d, {} crossed (< d/2), {} closer than 0.95 d; of one fibre (3 or more segments apart): {} crossed, {} closer than 0.95 d",
        stats.clusters as f64 / stats.preparations.max(1) as f64,
        stats.lock_steps,
        stats.wall_seconds,
        stats.candidate_pairs as f64 / stats.active_segments.max(1) as f64,
        least / d,
        crossed,
        close,
        self_crossed,
        self_close
    );
}
