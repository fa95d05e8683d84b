//! Numbers for people: significant digits, not fixed decimals.
//!
//! A fixed `{:.6}` prints a cost of 6.97e-6 as `0.000007` (one digit left) and a cost of
//! 12345.678 with eleven; [`significant`] keeps the same number of significant digits at every
//! magnitude, like C's `%g`: plain notation from 1e-4 up to `10^digits`, scientific outside,
//! trailing zeros dropped. Files keep the full round-trip precision; this is for text only.

/// `x` with `digits` significant digits (at least 1), `%g`-style: `significant(6.97e-6, 4)`
/// is `6.97e-6`, `significant(11.359616, 6)` is `11.3596`, `significant(2.0, 6)` is `2`.
/// Non-finite values print as `NaN`, `inf`, `-inf`.
pub fn significant(x: f64, digits: usize) -> String {
    let digits = digits.max(1);
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".to_string();
    }
    // The exponent after rounding to `digits` digits (9.9999 -> 1.0e1 moves it).
    let sci = format!("{:.*e}", digits - 1, x);
    let (mantissa, exp) = sci.split_once('e').expect("`{:e}` has an exponent");
    let exp: i32 = exp.parse().expect("`{:e}` has an integer exponent");
    if exp < -4 || exp >= digits as i32 {
        format!("{}e{exp}", trim_zeros(mantissa))
    } else {
        let decimals = (digits as i32 - 1 - exp).max(0) as usize;
        trim_zeros(&format!("{x:.decimals$}")).to_string()
    }
}

/// `1.2300` -> `1.23`, `2.000` -> `2`, `120` -> `120` (no decimal point: unchanged).
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::significant;

    #[test]
    fn keeps_significant_digits_at_every_magnitude() {
        assert_eq!(significant(6.97e-6, 4), "6.97e-6");
        assert_eq!(significant(11.359616203476822, 6), "11.3596");
        assert_eq!(significant(15.394760771339978, 7), "15.39476");
        assert_eq!(significant(2.0, 6), "2");
        assert_eq!(significant(-0.5, 3), "-0.5");
        assert_eq!(significant(0.00012345, 3), "0.000123");
        assert_eq!(significant(1.2345e-5, 3), "1.23e-5");
        assert_eq!(significant(123456.0, 4), "1.235e5");
        assert_eq!(significant(9999.6, 4), "1e4"); // rounding moves the exponent
        assert_eq!(significant(999.96, 4), "1000");
        assert_eq!(significant(0.0, 4), "0");
        assert_eq!(significant(f64::NAN, 4), "NaN");
        assert_eq!(significant(f64::NEG_INFINITY, 4), "-inf");
        assert_eq!(significant(1.5, 0), "2"); // at least one digit
    }

    #[test]
    fn reads_back_to_the_rounded_value() {
        for &x in &[3.0e-300, 7.77e-9, 0.1, 1.0 / 3.0, 42.0, 6.02e23, -2.5e-7] {
            let text = significant(x, 6);
            let back: f64 = text.parse().unwrap();
            assert!(((back - x) / x).abs() < 5e-6, "{x} -> {text}");
        }
    }
}
