//! Geometry of a fibre given as a polyline of nodes: the paper's shape measures.
//!
//! Both measures work for planar (belt plane) and 3D node lists.
//!
//! ```
//! use laydown::geometry::{radius_of_gyration, bending_energy};
//! // A straight fibre of length 1 m: S = L/sqrt(12), e = 0.
//! let nodes: Vec<[f64; 3]> = (0..=1000).map(|i| [i as f64 / 1000.0, 0.0, 0.0]).collect();
//! assert!((radius_of_gyration(&nodes) - 1.0 / 12f64.sqrt()).abs() < 1e-3);
//! assert!(bending_energy(&nodes).abs() < 1e-12);
//! ```

/// Radius of gyration S of the nodes about their centre of mass (eq 5):
/// S² = (1/N) Σ |r_i − r_O|².
pub fn radius_of_gyration(nodes: &[[f64; 3]]) -> f64 {
    let n = nodes.len();
    if n == 0 {
        return 0.0;
    }
    let mut centre = [0.0; 3];
    for p in nodes {
        for k in 0..3 {
            centre[k] += p[k];
        }
    }
    for c in &mut centre {
        *c /= n as f64;
    }
    let sum_sq: f64 = nodes
        .iter()
        .map(|p| (0..3).map(|k| (p[k] - centre[k]).powi(2)).sum::<f64>())
        .sum();
    (sum_sq / n as f64).sqrt()
}

/// A planar curve moved so that the mean of its nodes is the origin.
pub fn centred(nodes: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let n = nodes.len() as f64;
    let c = nodes.iter().fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
    nodes.iter().map(|p| [p[0] - c[0], p[1] - c[1]]).collect()
}

/// Direction (rad, in (−π, π]) of the chord from `a` to `b` in the belt plane.
pub fn chord_angle(a: [f64; 2], b: [f64; 2]) -> f64 {
    (b[1] - a[1]).atan2(b[0] - a[0])
}

/// Total arc length of the polyline.
pub fn arc_length(nodes: &[[f64; 3]]) -> f64 {
    nodes.windows(2).map(|w| distance(&w[0], &w[1])).sum()
}

/// Non-dimensional bending energy e = V_b L / EI = (L/2) ∫ κ² ds (eqs 6, A.3).
///
/// Discrete curvature at an interior node i is the turning angle φ_i between the
/// adjacent segments divided by the Voronoi length (|e_{i-1}| + |e_i|)/2, so
/// ∫ κ² ds ≈ Σ φ_i² / ((|e_{i-1}| + |e_i|)/2). This is exact for a circle sampled
/// at equal arc length: a full circle of length L gives e = 2π², an arc of turning
/// angle θ gives θ²/2.
pub fn bending_energy(nodes: &[[f64; 3]]) -> f64 {
    if nodes.len() < 3 {
        return 0.0;
    }
    let length = arc_length(nodes);
    let mut integral = 0.0;
    for w in nodes.windows(3) {
        let a = sub(&w[1], &w[0]);
        let b = sub(&w[2], &w[1]);
        let la = norm(&a);
        let lb = norm(&b);
        if la == 0.0 || lb == 0.0 {
            continue;
        }
        let turning_angle = turning_angle(&a, &b);
        integral += turning_angle * turning_angle / (0.5 * (la + lb));
    }
    0.5 * length * integral
}

/// Angle between two vectors in [0, π], robust for nearly parallel vectors (atan2 of |a×b| and a·b).
pub fn turning_angle(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let c = cross(a, b);
    norm(&c).atan2(dot(a, b))
}

pub fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
pub fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
pub fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    norm(&sub(a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn arc(length: f64, turning: f64, n: usize) -> Vec<[f64; 3]> {
        // n segments of equal length along a circular arc of the given total turning angle.
        let radius = length / turning;
        (0..=n)
            .map(|i| {
                let phi = turning * i as f64 / n as f64;
                [radius * phi.sin(), radius * (1.0 - phi.cos()), 0.0]
            })
            .collect()
    }

    #[test]
    fn straight_fibre() {
        let nodes: Vec<_> = (0..=2000).map(|i| [0.0, 0.0, i as f64 * 5e-4]).collect();
        let s = radius_of_gyration(&nodes);
        // Discrete nodes: S² = L²(N+2)/(12N) for N segments.
        let expected = (1.0f64 * (2000.0 + 2.0) / (12.0 * 2000.0)).sqrt();
        assert!((s - expected).abs() < 1e-12, "{s} vs {expected}");
        assert!((s - 0.2887).abs() < 1e-3);
        assert_eq!(bending_energy(&nodes), 0.0);
    }

    #[test]
    fn full_circle() {
        let nodes = arc(1.0, 2.0 * PI, 1000);
        let e = bending_energy(&nodes);
        // e = 2π² for the continuous circle. The end nodes carry no curvature, so the
        // discrete sum is exactly 2π²(n−1)/n for n equal segments.
        assert!((e - 2.0 * PI * PI * 999.0 / 1000.0).abs() < 1e-9, "e = {e}");
        assert!((e - 2.0 * PI * PI).abs() / (2.0 * PI * PI) < 1.1e-3, "e = {e}");
        // S = R for a circle (first and last node coincide: drop one).
        let s = radius_of_gyration(&nodes[..1000]);
        assert!((s - 1.0 / (2.0 * PI)).abs() < 1e-9, "S = {s}");
    }

    #[test]
    fn arc_energy() {
        for theta in [0.3, 1.0, 2.5] {
            let n = 500.0;
            let e = bending_energy(&arc(1.0, theta, 500));
            // Exact discrete value θ²(n−1)/(2n), converging to θ²/2 as 1/n.
            assert!((e - theta * theta * (n - 1.0) / (2.0 * n)).abs() < 1e-12, "θ={theta} e={e}");
        }
    }
}
