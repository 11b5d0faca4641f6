//! `lrmcal report DIR`: build `DIR/report.html` again from the
//! `report.json` that `identify` (or `demo`) wrote in DIR, without fitting
//! again: the page `identify` writes for the same report.

use std::path::PathBuf;

use lrmcal_engine::calib::results::report::Report;

use crate::error::Error;
use crate::report_page;

/// Build a calibration folder's one-page report (report.html) from its report.json.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal report cal\n  \
lrmcal report lrmcal-demo\n\n\
Reads DIR/report.json (written by `lrmcal identify` or `lrmcal demo`) and writes DIR/report.html: \
the summary table per model option, the errors before and after with their plots, the suspect \
measurements, the parameters with their deviations and which were held, the selection's \
observability, the knot choice, the registration and what to do next. The page is one file \
that loads nothing from anywhere.")]
pub struct Args {
    /// The folder `lrmcal identify --out` (or `lrmcal demo --out`) wrote.
    #[arg(value_name = "DIR")]
    pub dir: PathBuf,
}

/// Runs `lrmcal report`.
pub fn run(args: &Args) -> Result<(), Error> {
    let path = args.dir.join("report.json");
    let text = std::fs::read_to_string(&path).map_err(|source| {
        if source.kind() == std::io::ErrorKind::NotFound {
            Error::NoReport { path: path.clone() }
        } else {
            lrmcal_core::Error::Read {
                path: path.clone(),
                source,
            }
            .into()
        }
    })?;
    let report = Report::parse(&text).map_err(|e| e.in_file(&path))?;
    let page = report_page::write(&args.dir, &report)?;
    println!("wrote {}", page.display());
    Ok(())
}
