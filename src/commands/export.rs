//! `keypose export`: a checked sequence in another program's format.

use super::{CommandError, Verdict};

#[derive(Debug, Clone, clap::Subcommand)]
pub enum ExportFormat {}

pub fn run(format: &ExportFormat) -> Result<Verdict, CommandError> {
    match *format {}
}
