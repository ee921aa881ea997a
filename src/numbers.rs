//! Numbers as text: the one place that decides how the library prints a number. It imports
//! nothing from the crate, so that any module (errors, scene checks, labels, plots) can print
//! a value without reaching up the module graph.
//!
//! | function | for | examples |
//! |---|---|---|
//! | [`human`] | messages and progress lines: six significant digits | `0.0608755`, `3.5`, `1.25e-7` |
//! | [`exact`] | a value the user wrote and may copy back: every digit, exponent form outside `[1e-4, 1e7)` | `0.1`, `1e300` |
//! | [`decimals`] | labels: at most `d` decimals | `0.5`, `0.7222` |
//! | [`axis_tick`] | plot axes: enough decimals to tell ticks a tenth of the axis apart | `0.25`, `1.5e6` |
//! | [`push_round_trip`] | files (CSV, VTK, Matrix Market): shortest round trip, exponent form outside `[1e-5, 1e16)` | `0.1`, `1e-300` |

/// A number for people: at most six significant digits, trailing zeros dropped, plain between
/// `1e-4` and `1e6` and in exponent form outside (`0.0608755`, `22`, `1.25e-7`); zero and
/// non-finite values as Rust prints them.
pub fn human(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    if (1e-4..1e6).contains(&a) {
        let digits = (5 - a.log10().floor() as i32).max(0) as usize;
        trim_fraction(&format!("{x:.digits$}")).to_string()
    } else {
        exponent_form(&format!("{x:.5e}"))
    }
}

/// A number exactly as given: the shortest text that reads back to the same `f64`, in
/// exponent form outside `[1e-4, 1e7)` (`0.1`, `2500000`, `1e300`, `3e-9`).
pub fn exact(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `v` with at most `d` decimals, trailing zeros dropped (`decimals(0.5, 4)` is `0.5`,
/// `decimals(13.0 / 18.0, 4)` is `0.7222`).
pub fn decimals(v: f64, d: usize) -> String {
    trim_fraction(&format!("{v:.d$}")).to_string()
}

/// A tick label of a linear axis over `range`: decimals enough to tell ticks about a tenth of
/// the axis apart, in exponent form when the largest magnitude on the axis is at least 1e5 or
/// below 1e-3; values within a millionth of a tick spacing of zero print as `0`.
pub fn axis_tick(v: f64, range: std::ops::Range<f64>) -> String {
    let (step, big) = ((range.end - range.start) / 10.0, range.start.abs().max(range.end.abs()));
    let v = if v.abs() < step * 1e-6 { 0.0 } else { v + 0.0 }; // `+ 0.0` turns -0.0 into 0.0
    if (1e-3..1e5).contains(&big) {
        let decimals = (-step.log10().floor()).clamp(0.0, 12.0) as usize;
        return format!("{v:.decimals$}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let digits = (big / step).log10().ceil().clamp(0.0, 12.0) as usize;
    exponent_form(&format!("{v:.digits$e}"))
}

/// Appends `value` in the shortest form that reads back bit-for-bit with `str::parse::<f64>`:
/// Rust's `{}` for zero, non-finite values and magnitudes in `[1e-5, 1e16)`, and `{:e}` (also
/// shortest round-trip, e.g. `1e-300`) outside it, where `{}` would spell out hundreds of zeros.
/// NaN and the infinities are written `NaN`, `inf`, `-inf`; negative zero is `-0`.
pub fn push_round_trip(out: &mut String, value: f64) {
    use std::fmt::Write;
    let magnitude = value.abs();
    // Writing into a String cannot fail.
    if value == 0.0 || !value.is_finite() || (1e-5..1e16).contains(&magnitude) {
        let _ = write!(out, "{value}");
    } else {
        let _ = write!(out, "{value:e}");
    }
}

/// `text` without the trailing zeros of its fraction (and without the point if nothing is
/// left after it); text with no point is returned as it is.
fn trim_fraction(text: &str) -> &str {
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        text
    }
}

/// Rust's `{:.Ne}` text with the trailing zeros of the mantissa dropped (`1.50000e-7` →
/// `1.5e-7`).
fn exponent_form(text: &str) -> String {
    let (mantissa, exponent) = text.split_once('e').unwrap_or((text, "0"));
    format!("{}e{exponent}", trim_fraction(mantissa))
}

/// A byte count for people, in binary units: `512 B`, `12.5 MiB`, `29.8 GiB`.
pub fn bytes(b: f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{v:.0} B")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn human_keeps_six_significant_digits() {
        assert_eq!(human(0.060875512), "0.0608755");
        assert_eq!(human(3.5), "3.5");
        assert_eq!(human(22.0), "22");
        assert_eq!(human(1.25e-7), "1.25e-7");
        assert_eq!(human(-2.0e8), "-2e8");
        assert_eq!(human(0.0), "0");
    }

    #[test]
    fn exact_reads_back_to_the_same_value() {
        for v in [0.1, 2.5e6, 1e300, 3e-9, -7.25, 1.0 / 3.0] {
            assert_eq!(exact(v).parse::<f64>().unwrap(), v);
        }
        assert_eq!(exact(1e300), "1e300");
        assert_eq!(exact(0.5), "0.5");
    }

    #[test]
    fn decimals_and_ticks_drop_trailing_zeros() {
        assert_eq!(decimals(0.5, 4), "0.5");
        assert_eq!(decimals(13.0 / 18.0, 4), "0.7222");
        assert_eq!(decimals(1.0, 4), "1");
        assert_eq!(axis_tick(0.3, 0.0..1.0), "0.3");
        assert_eq!(axis_tick(1.5e6, 0.0..2.0e6), "1.5e6");
        assert_eq!(axis_tick(1e-9, 0.0..2.0e6), "0");
    }
}
