//! Axis ticks: where they go and how they read.
//!
//! Every axis of a figure gets its ticks here rather than from `plotters`' defaults, so
//! that a log axis always has at least two labelled ticks inside its range (decades,
//! else 1-2-5 steps, else plain steps), an integer axis (replicate, fibre) only integer
//! ticks, and the labels of one axis share one notation (`8000, 22000` or
//! `8×10³, 2.2×10⁴`, never a mix). The caller bounds the number of ticks by the room
//! the labels take, so labels do not run into each other.

/// Tick positions in `[lo, hi]` on a linear axis, at most `max_count` (at least 2 when
/// the range allows), on a 1-2-5 step (no 2.5: labels keep one decimal less); integers
/// only if `integer`.
pub fn linear(lo: f64, hi: f64, max_count: usize, integer: bool) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return if lo.is_finite() { vec![lo] } else { vec![] };
    }
    let max_count = max_count.max(2);
    let span = hi - lo;
    let mut exp = (span / max_count as f64).log10().floor() as i32 - 1;
    loop {
        for m in [1.0, 2.0, 5.0] {
            let step = m * 10f64.powi(exp);
            if integer && step < 1.0 {
                continue;
            }
            let first = (lo / step - 1e-9).ceil();
            let last = (hi / step + 1e-9).floor();
            let n = (last - first) as i64 + 1;
            if n >= 1 && n as usize <= max_count {
                return (0..n).map(|k| clean((first + k as f64) * step)).collect();
            }
        }
        exp += 1;
        if exp > 300 {
            return vec![lo, hi];
        }
    }
}

/// Tick positions in `[lo, hi]` (both > 0) on a log axis, at most `max_count`: whole
/// decades (every k-th if there are too many), else 1-2-5 steps, else linear steps when
/// the range is narrower than a factor 2.
pub fn log(lo: f64, hi: f64, max_count: usize) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return linear(lo, hi, max_count, false);
    }
    let max_count = max_count.max(2);
    let (a, b) = ((lo.log10() - 1e-9).ceil() as i32, (hi.log10() + 1e-9).floor() as i32);
    let decades = (b - a + 1).max(0) as usize;
    if decades >= 2 {
        let every = decades.div_ceil(max_count).max(1) as i32;
        // the multiples of `every`, so 10⁰ stays a tick when it is in range
        let ticks: Vec<f64> = (a..=b).filter(|k| k.rem_euclid(every) == 0).map(|k| clean(10f64.powi(k))).collect();
        if ticks.len() >= 2 {
            return ticks;
        }
        return (a..=b).step_by(every as usize).map(|k| clean(10f64.powi(k))).collect();
    }
    for mantissas in [&[1.0, 2.0, 5.0][..], &[1.0, 2.0, 3.0, 5.0][..], &[1.0, 1.5, 2.0, 3.0, 5.0, 7.0][..]] {
        let ticks: Vec<f64> = (a - 1..=b + 1)
            .flat_map(|k| mantissas.iter().map(move |m| clean(m * 10f64.powi(k))))
            .filter(|v| *v >= lo * (1.0 - 1e-9) && *v <= hi * (1.0 + 1e-9))
            .collect();
        if ticks.len() >= 2 && ticks.len() <= max_count {
            return ticks;
        }
        if ticks.len() > max_count {
            break;
        }
    }
    let t = linear(lo, hi, max_count.min(5), false);
    t.into_iter().filter(|v| *v > 0.0).collect()
}

/// Round off the binary noise of `k × step` (0.30000000000000004 → 0.3).
fn clean(v: f64) -> f64 {
    if v == 0.0 {
        return 0.0;
    }
    let digits = 12 - v.abs().log10().floor() as i32;
    let f = 10f64.powi(digits.clamp(-300, 300));
    (v * f).round() / f
}

/// Whether values this large or small read better in powers of ten.
fn needs_powers(largest: f64, smallest: f64) -> bool {
    largest >= 1e5 || (smallest > 0.0 && smallest < 1e-3)
}

/// Labels of the ticks of one axis, in one notation: plain decimals with the same
/// number of decimals, or all in powers of ten (`10⁻³`, `2.5×10⁴`).
pub fn format(ticks: &[f64]) -> Vec<String> {
    let nonzero: Vec<f64> = ticks.iter().map(|v| v.abs()).filter(|v| *v > 0.0 && v.is_finite()).collect();
    let largest = nonzero.iter().copied().fold(0.0, f64::max);
    let smallest = nonzero.iter().copied().fold(f64::INFINITY, f64::min);
    if needs_powers(largest, smallest) {
        let digits = (0..=3).find(|&d| ticks.iter().all(|&v| exact(mantissa(v).0, d))).unwrap_or(3);
        return ticks.iter().map(|&v| power_of_ten(v, digits)).collect();
    }
    let digits = (0..=8).find(|&d| ticks.iter().all(|&v| exact(v, d))).unwrap_or(8);
    ticks.iter().map(|&v| fixed(v, digits)).collect()
}

/// One value in the notation [`format()`] would give it alone, with at most 3 significant
/// digits (for titles: `v_b/v_f = 0.05`, `d = 30 µm`).
pub fn format_one(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let rounded = {
        let digits = 2 - a.log10().floor() as i32;
        let f = 10f64.powi(digits);
        (v * f).round() / f
    };
    format(&[rounded]).remove(0)
}

fn exact(v: f64, digits: i32) -> bool {
    let f = 10f64.powi(digits);
    ((v * f).round() / f - v).abs() <= 1e-9 * v.abs().max(1e-300)
}

fn fixed(v: f64, digits: i32) -> String {
    let s = format!("{:.*}", digits as usize, v);
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s.replace('-', "−")
    }
}

fn mantissa(v: f64) -> (f64, i32) {
    if v == 0.0 {
        return (0.0, 0);
    }
    let e = v.abs().log10().floor() as i32;
    let m = v / 10f64.powi(e);
    // 9.9999 → 10
    if (m.abs() - 10.0).abs() < 1e-9 {
        (m.signum(), e + 1)
    } else {
        (m, e)
    }
}

fn superscript(e: i32) -> String {
    e.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        })
        .collect()
}

fn power_of_ten(v: f64, digits: i32) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let (m, e) = mantissa(v);
    if (m.abs() - 1.0).abs() < 1e-9 && digits == 0 {
        let sign = if m < 0.0 { "−" } else { "" };
        return format!("{sign}10{}", superscript(e));
    }
    format!("{}×10{}", fixed(m, digits), superscript(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axes_have_two_labelled_ticks_inside_any_range() {
        for (lo, hi) in [(0.5, 3.0), (90.0, 110.0), (1e-4, 1e2), (3e3, 2.5e4), (0.011, 0.019), (1.0, 1e30)] {
            let t = log(lo, hi, 6);
            assert!(t.len() >= 2 && t.len() <= 6, "{lo}..{hi}: {t:?}");
            assert!(t.iter().all(|v| *v >= lo * 0.999 && *v <= hi * 1.001), "{lo}..{hi}: {t:?}");
        }
        assert_eq!(log(0.5, 30.0, 6), vec![1.0, 10.0]);
        assert_eq!(log(0.5, 3.0, 6), vec![0.5, 1.0, 2.0]);
    }

    #[test]
    fn integer_axes_get_integer_ticks() {
        assert_eq!(linear(-0.2, 1.2, 8, true), vec![0.0, 1.0]);
        assert!(linear(-0.5, 37.0, 6, true).iter().all(|v| v.fract() == 0.0));
        assert_eq!(linear(0.0, 1.0, 6, false), vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
    }

    #[test]
    fn one_axis_one_notation() {
        assert_eq!(format(&[0.0, 0.5, 1.0]), ["0.0", "0.5", "1.0"]);
        assert_eq!(format(&[8000.0, 22000.0]), ["8000", "22000"]);
        assert_eq!(format(&[8000.0, 220000.0]), ["8.0×10³", "2.2×10⁵"], "one number of decimals");
        assert_eq!(format(&[1e-4, 1e-3, 1e-2]), ["10⁻⁴", "10⁻³", "10⁻²"]);
        assert_eq!(format(&[-0.1, 0.0, 0.1]), ["−0.1", "0.0", "0.1"]);
        assert_eq!(format_one(3e-5 * 1e6), "30");
        assert_eq!(format_one(0.0512), "0.0512");
    }
}
