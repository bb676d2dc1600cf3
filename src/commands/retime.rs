//! `keypose retime`: stretch key times until velocity and acceleration limits hold.

use super::{parse_check_rate, write_output, CommandError, SequenceInput, Verdict};
use keypose::plan::{advice, retime};
use keypose::terminal_text::escape_controls;
use std::path::PathBuf;

#[derive(Debug, Clone, clap::Args)]
pub struct RetimeArgs {
    #[command(flatten)]
    pub input: SequenceInput,
    /// Where to write the retimed sequence [default: standard output].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Control rate the result is for [default: the robot's control rate; never below it]: a
    /// linear corner is turned within one period, so a faster rate needs a gentler corner.
    #[arg(long, value_name = "HZ", value_parser = parse_check_rate, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// As fast as the joints' velocity and acceleration limits allow along the path: every
    /// moving segment gets a timing profile (its curve unchanged), keys, holds and steps stay.
    #[arg(long)]
    pub fastest: bool,
}

pub fn run(args: &RetimeArgs) -> Result<Verdict, CommandError> {
    let (sequence, robot) = args.input.load()?;
    let rate = super::limit_check_rate(args.rate, &robot);
    super::check_sample_budget(
        &sequence.file,
        &keypose::plan::Trajectory::build(&sequence, &robot)?,
        rate,
    )?;
    if args.fastest {
        return run_fastest(args, &sequence, &robot, rate);
    }
    let outcome = retime(&sequence, &robot, rate)?;
    for (segment, before, after) in &outcome.stretched {
        let line = format!(
            "segment {segment} ({} → {}): {before:.3} s → {after:.3} s",
            sequence.keyframes[*segment].label(*segment),
            sequence.keyframes[segment + 1].label(segment + 1),
        );
        eprintln!("{}", escape_controls(&line));
    }
    if outcome.stretched.is_empty() {
        eprintln!("no segment needed stretching");
    }
    if report_unfixable(&sequence, &outcome.report) {
        return Ok(Verdict::Fail);
    }
    write_output(args.output.as_deref(), &outcome.sequence.to_json())?;
    Ok(Verdict::Pass)
}

fn run_fastest(
    args: &RetimeArgs,
    sequence: &keypose::sequence::Sequence,
    robot: &keypose::robot::Robot,
    rate: f64,
) -> Result<Verdict, CommandError> {
    let outcome = keypose::plan::fastest(sequence, robot, rate)?;
    for (segment, before, after) in &outcome.segments {
        let line = format!(
            "segment {segment} ({} → {}): {before:.3} s → {after:.3} s",
            sequence.keyframes[*segment].label(*segment),
            sequence.keyframes[segment + 1].label(segment + 1),
        );
        eprintln!("{}", escape_controls(&line));
    }
    for (key, before, after) in &outcome.holds {
        let line = format!(
            "hold of key {key} ({}): {before:.3} s → {after:.3} s (a joint moves through it: \
             too short to stop and start again within the jerk limits)",
            sequence.keyframes[*key].label(*key),
        );
        eprintln!("{}", escape_controls(&line));
    }
    let (before, after) = outcome.moving_time();
    eprintln!(
        "moving time {before:.3} s → {after:.3} s ({} plan-and-check round(s))",
        outcome.rounds
    );
    if report_unfixable(sequence, &outcome.report) {
        return Ok(Verdict::Fail);
    }
    write_output(args.output.as_deref(), &outcome.sequence.to_json())?;
    Ok(Verdict::Pass)
}

/// Prints what timing cannot fix — violations and contacts — each with its advice; whether
/// there was any.
fn report_unfixable(
    sequence: &keypose::sequence::Sequence,
    report: &keypose::plan::CheckReport,
) -> bool {
    let contacts: Vec<_> = report.undeclared_contacts().collect();
    if !contacts.is_empty() {
        eprintln!("{} contact(s) cannot be fixed by retiming:", contacts.len());
        for c in &contacts {
            let line = format!(
                "  {} with {} in segment {} ({}) at t = {:.3} s: {:.1} mm — {}",
                c.bodies.0,
                c.bodies.1.as_deref().unwrap_or("the floor"),
                c.segment,
                c.segment_label,
                c.deepest_time,
                c.distance * 1000.0,
                c.advice
            );
            eprintln!("{}", escape_controls(&line));
        }
    }
    let overloads: Vec<_> = report.overloads().collect();
    if !overloads.is_empty() {
        eprintln!(
            "{} servo overload(s) are left (stretching to the limits does not judge torque):",
            overloads.len()
        );
        for o in &overloads {
            eprintln!("  {} — {}", escape_controls(&o.describe()), o.advice);
        }
    }
    let remaining = &report.violations;
    if remaining.is_empty() {
        return !contacts.is_empty() || !overloads.is_empty();
    }
    eprintln!(
        "{} violation(s) cannot be fixed by retiming:",
        remaining.len()
    );
    for v in remaining {
        let hint = advice(sequence, v);
        let measure = match v.acceleration_jump {
            Some(jump) => format!(
                "the acceleration jumps by {jump:.3} (limit {:.3} per s³)",
                v.limit.abs()
            ),
            None => format!("{:.3} vs limit {:.3}", v.peak, v.limit),
        };
        let line = format!(
            "  {} {} in segment {} ({}) at t = {:.3} s: {measure} — {hint}",
            v.joint,
            v.kind.name(),
            v.segment,
            v.segment_label,
            v.peak_time,
        );
        eprintln!("{}", escape_controls(&line));
    }
    true
}
