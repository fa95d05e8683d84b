//! Quoting user input in messages: never more than a few hundred characters of it.
//!
//! An error names what was wrong with an input and shows the input, but a hostile or
//! accidental input can be megabytes on one line (a CSV line, a TOML value, a command-line
//! argument); echoing it whole floods the terminal and hides the message.

/// Characters of input shown at most.
pub const MAX_ECHO_CHARS: usize = 200;

/// At most `max_chars` characters of `s`, with `…` if cut.
pub fn clip_to(s: &str, max_chars: usize) -> String {
    match s.char_indices().nth(max_chars) {
        Some((end, _)) => format!("{}…", &s[..end]),
        None => s.to_string(),
    }
}

/// `text` quoted (Rust debug syntax), cut after [`MAX_ECHO_CHARS`] characters with `…` and the
/// total length.
pub fn echo(text: &str) -> String {
    match text.char_indices().nth(MAX_ECHO_CHARS) {
        Some((cut, _)) => format!(
            "{:?}… ({} characters in all)",
            &text[..cut],
            text.chars().count()
        ),
        None => format!("{text:?}"),
    }
}

/// A path for a message: whole up to [`MAX_ECHO_CHARS`] characters, else its start and its
/// end (where the file name is) around `…`, with the total length.
pub fn path(p: &std::path::Path) -> String {
    let text = p.display().to_string();
    let n = text.chars().count();
    if n <= MAX_ECHO_CHARS {
        return text;
    }
    let head: String = text.chars().take(60).collect();
    let tail: String = text.chars().skip(n - 120).collect();
    format!("{head}…{tail} ({n} characters in all)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_input_is_cut() {
        assert_eq!(echo("1,2"), "\"1,2\"");
        let long = "é".repeat(10_000);
        let e = echo(&long);
        assert!(e.chars().count() < MAX_ECHO_CHARS + 40, "{e}");
        assert!(e.ends_with("(10000 characters in all)"), "{e}");
    }
}

/// A number in a message: plain when short, in exponent notation when huge or tiny (so that
/// `1e300` is not printed with 300 digits).
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-5..1e16).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

#[cfg(test)]
mod num_tests {
    use super::Num;

    #[test]
    fn huge_and_tiny_numbers_are_printed_in_exponent_notation() {
        assert_eq!(Num(1e300).to_string(), "1e300");
        assert_eq!(Num(-1e-300).to_string(), "-1e-300");
        assert_eq!(Num(5e-324).to_string(), "5e-324");
        assert_eq!(Num(0.25).to_string(), "0.25");
        assert_eq!(Num(0.0).to_string(), "0");
        assert_eq!(Num(f64::NAN).to_string(), "NaN");
        // The stage messages use it (a target of 1e300 printed 301 digits).
        let s = crate::lie::solve::where_stopped("eta", 0.0, 1e300);
        assert_eq!(s, " at eta = 0 (target 1e300)");
    }
}

/// A cost in a message: six decimals (as `{:.6}`), or six significant digits in exponent
/// notation below 1e-3, where six decimals would print `0.000000` for every cost compared.
#[derive(Debug, Clone, Copy)]
pub struct Cost(pub f64);

impl std::fmt::Display for Cost {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-3..1e16).contains(&a) {
            write!(f, "{:.6}", self.0)
        } else {
            write!(f, "{:.5e}", self.0)
        }
    }
}

#[cfg(test)]
mod cost_tests {
    use super::Cost;

    #[test]
    fn small_costs_keep_their_digits() {
        assert_eq!(Cost(15.394760771339978).to_string(), "15.394761");
        assert_eq!(Cost(2.5e-7).to_string(), "2.50000e-7");
        assert_eq!(Cost(3.6512e-7).to_string(), "3.65120e-7");
        assert_eq!(Cost(0.0).to_string(), "0.000000");
    }
}
