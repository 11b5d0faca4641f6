//! Command-line parsing and dispatch for `lrmcal`.
//!
//! Adding a subcommand is a three-line change plus one file:
//! 1. write `src/commands/<name>.rs` with `pub struct Args` (`#[derive(clap::Args)]`,
//!    doc comments become the help) and `pub fn run(args: &Args) -> Result<(), Error>`,
//!    and add its `pub mod <name>;` line to `src/commands/mod.rs`;
//! 2. add one variant to [`Command`] below, with a doc comment (the one-line help);
//! 3. add one arm to the `match` in [`Command::run`].
//!
//! Errors are reported here, once: the message chain after "error: failed to",
//! and the exit code of [`Error::exit_code`].

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use crate::commands;
use crate::error::Error;
use lrmcal_core::io::arm_source::ArmSource;

/// Calibrate a cheap arm (3D-printed links, hobby servos; any serial arm of 1
/// to 10 joints) from measured 3D tool positions, and predict where it really goes.
#[derive(Debug, Parser)]
#[command(
    name = "lrmcal",
    version,
    about,
    long_about = "Calibrate a cheap arm (3D-printed links, hobby RC servos, no encoders; any \
serial arm of 1 to 10 revolute or prismatic joints) from measured 3D positions of its tool point.\n\n\
The arm is described by a TOML file (geometry, masses, servo curves) or read from a URDF \
(--arm robot.urdf --base-link L --tip-link L); measurements and \
pose lists are CSV files with angles in degrees and positions in millimetres; a \
calibration is a JSON file holding the calibrated arm. Every command that needs an arm \
uses the bundled LRM-like arm when --arm is omitted, so the commands below work on a \
fresh checkout with no files of your own; `--arm so101` is the bundled SO-101 (5 joints). \
The formats are described in docs/FORMATS.md of the source tree.",
    after_help = "Examples:\n  \
lrmcal demo                       # the whole method on a simulated arm\n  \
lrmcal demo --arm so101           # the same on the SO-101 desktop arm\n  \
lrmcal plan --out candidates.csv\n  \
lrmcal simulate --poses candidates.csv --out measurements.csv\n  \
lrmcal identify --measurements measurements.csv --load-kg 0.0663 --select 50 --out cal\n  \
lrmcal report cal                 # cal/report.html again from cal/report.json\n  \
lrmcal predict --arm cal/calibration-elasto-kinematic-servo.json --poses poses.csv --out predicted.csv\n  \
lrmcal help identify\n\n\
Exit codes: 0 success, 2 usage error, 3 invalid input file, 4 file could not be read or \
written, 5 model evaluation failed, 6 the board could not be reached or refused (or the \
emulated board could not be started)."
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
    /// With a URDF --arm: the link its serial chain starts at [default: the
    /// file's one root link].
    #[arg(long, global = true, value_name = "LINK")]
    pub base_link: Option<String>,
    /// With a URDF --arm: the link the chain ends at, whose origin is the
    /// measured point's frame [default: the one link without children below
    /// the base link].
    #[arg(long, global = true, value_name = "LINK")]
    pub tip_link: Option<String>,
}

impl Cli {
    /// Hands --base-link and --tip-link to the command's URDF --arm; refuses
    /// them for any other arm.
    fn with_chain_links(mut self) -> Result<Command, Error> {
        if self.base_link.is_none() && self.tip_link.is_none() {
            return Ok(self.command);
        }
        match self.command.arm_mut() {
            Some(ArmSource::Urdf {
                base_link,
                tip_link,
                ..
            }) => {
                *base_link = self.base_link.take();
                *tip_link = self.tip_link.take();
                Ok(self.command)
            }
            other => Err(Error::Usage(format!(
                "--base-link and --tip-link choose the chain of a URDF --arm (a .urdf file); \
                 the arm here is {}",
                other.map_or("not given".to_owned(), |a| a.to_string())
            ))),
        }
    }
}

/// The subcommands of `lrmcal`, one file each under `src/commands/`.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Predict tool positions of an arm (nominal or calibrated) for a pose list.
    Predict(commands::predict::Args),
    /// Simulate tracker measurements of a real arm drawn around the nominal one.
    Simulate(commands::simulate::Args),
    /// Generate the candidate poses: a grid of joint levels without collisions.
    Plan(commands::plan::Args),
    /// Run the whole calibration on a simulated arm: select, identify, validate, plot.
    Demo(commands::demo::Args),
    /// Identify the error parameters from measurements and write a calibration file.
    Identify(commands::identify::Args),
    /// Choose the poses to measure: D-optimal selection (DETMAX) from candidates.
    Select(commands::select::Args),
    /// Check a calibration against another measurement file.
    Validate(commands::validate::Args),
    /// Build a calibration folder's one-page report (report.html) again from its report.json.
    Report(commands::report::Args),
    /// List the serial ports a board could be on.
    Ports(commands::ports::Args),
    /// Show the board's versions, calibration, compensation, joints and faults.
    Status(commands::status::Args),
    /// Send a calibration file to the board (stored in flash, used at once).
    Push(commands::push::Args),
    /// Read the calibration stored on the board.
    Pull(commands::pull::Args),
    /// Move the arm to nominal joint angles (degrees), or its tool point to a position (--xyz).
    Move(commands::move_::Args),
    /// Move the arm to its home pose.
    Home(commands::home::Args),
    /// Make servos limp (or drive them again with --attach).
    Detach(commands::detach::Args),
    /// Tell the board the payload mass at the tool.
    Payload(commands::payload::Args),
    /// Switch real-time compensation off, to elastic only, or to full.
    Compensation(commands::compensation::Args),
    /// Tune one servo's pulse curve at the terminal (level-1 calibration).
    ServoTune(commands::servo_tune::Args),
    /// Drive the board through a pose list and record tracker positions.
    Measure(commands::measure::Args),
    /// Put a firmware image (UF2) on the board through its USB bootloader.
    Flash(commands::flash::Args),
    /// Run the board's real firmware in an emulated RP2040 (no hardware needed).
    Emulator(commands::emulator::Args),
    /// Export an arm for other tools: a URDF of its rigid geometry for ROS.
    Export(commands::export::Args),
    /// Find the board's AprilTag corners in image files and write them as a CSV.
    Detect(commands::detect::Args),
    /// Write the AprilTag board as a page to print (SVG, true size).
    PrintBoard(commands::print_board::Args),
    /// Turn a recorded tracker take (OptiTrack Motive CSV) into a measurement CSV.
    ImportTracker(commands::import_tracker::Args),
}

impl Command {
    /// The command's --arm, if it takes one and it is given.
    fn arm_mut(&mut self) -> Option<&mut ArmSource> {
        match self {
            Self::Predict(args) => Some(&mut args.arm),
            Self::Simulate(args) => Some(&mut args.arm),
            Self::Plan(args) => Some(&mut args.arm),
            Self::Demo(args) => Some(&mut args.arm),
            Self::Identify(args) => Some(&mut args.arm),
            Self::Select(args) => Some(&mut args.arm),
            Self::Validate(args) => args.arm.as_mut(),
            Self::Move(args) => args.arm.as_mut(),
            Self::Measure(args) => args.arm.as_mut(),
            Self::Export(args) => args.arm.as_mut(),
            _ => None,
        }
    }

    /// Runs the chosen subcommand.
    pub fn run(&self) -> Result<(), Error> {
        match self {
            Self::Predict(args) => commands::predict::run(args),
            Self::Simulate(args) => commands::simulate::run(args),
            Self::Plan(args) => commands::plan::run(args),
            Self::Demo(args) => commands::demo::run(args, &run_line),
            Self::Identify(args) => commands::identify::run(args),
            Self::Select(args) => commands::select::run(args),
            Self::Validate(args) => commands::validate::run(args),
            Self::Report(args) => commands::report::run(args),
            Self::Ports(args) => commands::ports::run(args),
            Self::Status(args) => commands::status::run(args),
            Self::Push(args) => commands::push::run(args),
            Self::Pull(args) => commands::pull::run(args),
            Self::Move(args) => commands::move_::run(args),
            Self::Home(args) => commands::home::run(args),
            Self::Detach(args) => commands::detach::run(args),
            Self::Payload(args) => commands::payload::run(args),
            Self::Compensation(args) => commands::compensation::run(args),
            Self::ServoTune(args) => commands::servo_tune::run(args),
            Self::Measure(args) => commands::measure::run(args),
            Self::Flash(args) => commands::flash::run(args),
            Self::Emulator(args) => commands::emulator::run(args),
            Self::Export(args) => commands::export::run(args),
            Self::ImportTracker(args) => commands::import_tracker::run(args),
            Self::Detect(args) => commands::detect::run(args),
            Self::PrintBoard(args) => commands::print_board::run(args),
        }
    }
}

/// Runs the command line `argv` (its first word the program's name) as
/// `lrmcal` would: the demo's camera path runs the commands a user types.
pub(crate) fn run_line(argv: &[String]) -> Result<(), Error> {
    Cli::try_parse_from(argv)
        .map_err(|e| Error::Usage(e.to_string()))?
        .with_chain_links()?
        .run()
}

/// Parses the process arguments, runs the command and turns its outcome into an
/// exit code, printing any error with its causes to stderr.
pub fn main_impl() -> ExitCode {
    let outcome = Cli::parse().with_chain_links().and_then(|c| c.run());
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("{}", error.report());
            ExitCode::from(error.exit_code())
        }
    }
}
