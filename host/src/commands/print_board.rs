//! `lrmcal print-board`: the AprilTag board of a board file as an SVG page
//! to print at its true size.

use std::path::PathBuf;

use crate::commands::helpers::write_text;
use crate::error::Error;
use lrmcal_core::camera::board;
use lrmcal_engine::camera::printed_board;

/// Write the AprilTag board as a page to print (SVG, true size).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "The page holds the board file's grid of tag36h11 tags, each tag's \
black square the file's tagSize, with a white margin around the grid and a caption: print it \
at 100 % (no \"fit to page\") and check the tag size with a ruler; if it differs, write the \
measured size into the board file. Glue it flat on a rigid plate fixed to the flange; the board \
frame (the caption says where) is what the camera setup's [board] places on the flange.\n\n\
Examples:\n  \
lrmcal print-board --board board.yaml --out board.svg"
)]
pub struct Args {
    /// The board: Kalibr's aprilgrid YAML.
    #[arg(long, value_name = "FILE")]
    pub board: PathBuf,
    /// Where to write the page (SVG).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
}

/// Runs `lrmcal print-board`.
pub fn run(args: &Args) -> Result<(), Error> {
    let board = board::read(&args.board)?;
    let page = printed_board::svg(&board).ok_or_else(|| {
        Error::Usage(format!(
            "{}: a tag id is past the tag36h11 family's 587",
            args.board.display()
        ))
    })?;
    write_text(&args.out, &page)?;
    println!(
        "wrote {}: {} tags of {:.1} mm, print at 100 %",
        args.out.display(),
        board.tag_count(),
        board.tag_size_m * 1e3
    );
    Ok(())
}
