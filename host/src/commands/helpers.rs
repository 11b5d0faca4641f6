//! What several subcommands share: the `--option` choice of one model
//! option or all, writing a text file whole, and the parsers of finite,
//! positive and non-negative numbers. Commands never import each other:
//! what two of them need lives here (or in `device_args`).

use std::path::Path;

use crate::error::Error;
use lrmcal_core::io::atomic;
use lrmcal_engine::calib::ModelOption;

/// Which options to fit: one, or all of them for comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OptionChoice {
    /// One option.
    One(ModelOption),
    /// Every option: the paper's three and ours.
    All,
}

impl std::str::FromStr for OptionChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match (s, ModelOption::from_name(s)) {
            ("all", _) => Ok(Self::All),
            (_, Some(option)) => Ok(Self::One(option)),
            (_, None) => Err(format!(
                "unknown model option `{s}`: expected {} or all",
                lrmcal_core::io::model_option::names()
            )),
        }
    }
}

impl std::fmt::Display for OptionChoice {
    /// The name [`OptionChoice::from_str`] reads.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::One(option) => f.write_str(option.name()),
            Self::All => f.write_str("all"),
        }
    }
}

impl OptionChoice {
    /// The options to run, in the table order (the paper's, then ours).
    pub fn options(self) -> Vec<ModelOption> {
        match self {
            Self::One(o) => vec![o],
            Self::All => ModelOption::ALL.to_vec(),
        }
    }
}

/// Writes a text file (JSON, a report) whole or not at all (see [`atomic`]).
pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), Error> {
    Ok(atomic::write(path, |w| w.write_all(text.as_bytes()))?)
}

/// A clap parser for a finite height, mm, of either sign (`--ground-z-mm`).
pub(crate) fn finite_height_mm(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("expected a finite height in mm, found `{text}`")),
    }
}

/// A clap parser for a finite number > 0.
pub(crate) fn positive(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a finite number > 0, found `{text}`")),
    }
}

/// A clap parser for a finite number >= 0.
pub(crate) fn non_negative(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a finite number >= 0, found `{text}`")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_choice_parses_each_name_and_all() {
        for o in ModelOption::ALL {
            assert_eq!(o.name().parse(), Ok(OptionChoice::One(o)));
        }
        assert_eq!(
            "all".parse::<OptionChoice>().map(|c| c.options().len()),
            Ok(4)
        );
        for choice in [OptionChoice::All, OptionChoice::One(ModelOption::Elastic)] {
            assert_eq!(choice.to_string().parse(), Ok(choice));
        }
        let e = "rigid".parse::<OptionChoice>().unwrap_err();
        assert!(
            e.contains("rigid")
                && e.contains(
                    "kinematic, elastic, elasto-kinematic, elasto-kinematic-servo, paper-kinematic or paper-elasto-kinematic or all"
                )
        );
    }
}
