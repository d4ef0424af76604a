//! How numbers are written in reports: an optional value, and an error bar rounded up.

/// `x` with `digits` decimals, or `-` when absent.
pub(super) fn maybe(x: Option<f64>, digits: usize) -> String {
    x.map_or("-".into(), |v| format!("{v:.digits$}"))
}

/// `x` (positive) in scientific notation with `digits` significant digits, rounded up: an error
/// bar is never shown smaller than it was estimated (`2.85e-4` is `2.9e-4`, not `2.8e-4`).
pub(super) fn rounded_up(x: f64, digits: i32) -> String {
    if !(x.is_finite() && x > 0.0) {
        return format!("{x:.e}");
    }
    let exponent = x.log10().floor() as i32;
    let unit = 10f64.powi(exponent - digits + 1);
    // The quotient is rounded first so that an x already at the digits is not pushed up by
    // the representation error of the division.
    let mantissa = ((x / unit * 1e9).round() / 1e9).ceil() * unit / 10f64.powi(exponent);
    let (mantissa, exponent) = if mantissa >= 10.0 {
        (mantissa / 10.0, exponent + 1)
    } else {
        (mantissa, exponent)
    };
    format!("{mantissa:.prec$}e{exponent}", prec = (digits - 1) as usize)
}

#[cfg(test)]
mod tests {
    use super::rounded_up;

    #[test]
    fn error_bars_are_rounded_up_to_their_digits() {
        assert_eq!(rounded_up(2.85e-4, 2), "2.9e-4");
        assert_eq!(rounded_up(2.8e-4, 2), "2.8e-4");
        assert_eq!(rounded_up(5.68e-4, 1), "6e-4");
        assert_eq!(rounded_up(5.01e-4, 1), "6e-4");
        assert_eq!(rounded_up(9.96e-3, 2), "1.0e-2");
        assert_eq!(rounded_up(1.0, 2), "1.0e0");
    }
}
