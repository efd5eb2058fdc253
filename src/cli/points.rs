//! `hystid identify-points`: flags into a [`PointsRequest`], its report
//! onto the terminal.

use super::args::IdentifyPointsArgs;
use super::{EXIT_DEGRADED, EXIT_OK, create_out_dir, progress, reduction_options, refused};
use anyhow::Result;
use hystid::analysis::points::{PointsReport, PointsRequest, identify_points};

/// `hystid identify-points`.
pub fn identify_points_command(args: &IdentifyPointsArgs, quiet: bool) -> Result<u8> {
    let request = PointsRequest {
        recordings: args.recordings.clone(),
        responses: args.responses.clone(),
        drive: args
            .drive
            .clone()
            .unwrap_or_else(|| args.responses[0].clone()),
        joint: args.joint.clone(),
        law: args.law.clone(),
        band_hz: args.band.clone(),
        modes: args.modes,
        outside_hz: args.outside_hz.clone(),
        reduction: reduction_options(&args.reduction)?,
    };
    request.validate().map_err(refused)?;
    let _out = create_out_dir(&args.out)?;
    let pb = progress::spinner("identify-points", quiet);
    let report = identify_points(&request, &args.out, &progress::BarObserver(&pb));
    pb.finish_and_clear();
    let report = report.map_err(refused)?;
    if !quiet {
        print_report(&report);
    }
    Ok(if report.fit.failed_lines == 0 {
        EXIT_OK
    } else {
        EXIT_DEGRADED
    })
}

fn print_report(r: &PointsReport) {
    say!("hystid identify-points: {}", r.joint_in_words());
    if !r.fit.at_bounds.is_empty() {
        say!(
            "  at a bound of its range (not a value found): {}",
            r.fit.at_bounds.join(", ")
        );
    }
    if r.fit.restarted {
        say!("  restarted with those held at their bound; the better fit is kept");
    }
    for m in &r.structure.modes {
        say!(
            "  mode {:.3} Hz, damping {:.3} %",
            m.frequency_hz,
            100.0 * m.damping_ratio
        );
    }
    for e in &r.errors {
        say!(
            "  {} at {}: FRF error {:.1} %",
            e.response,
            hystid::plot::level_label(e.level, "N"),
            e.frf_error_percent
        );
    }
    if r.fit.failed_lines > 0 {
        say!("  WARNING: {} lines not solved", r.fit.failed_lines);
    }
    for f in &r.files {
        say!("  wrote {}", f.display());
    }
}
