//! The F-16 at three points: import, reduction, fits and judgements.

use super::protocols;
use hystid::analysis::points::{PointsRequest, reduce_at_sensors};
use hystid::analysis::recording::{ChannelChoice, ReductionOptions, SineTest, load_recording};
use hystid::extract::SweepFit;
use hystid::fit::Weighting;
use hystid::fit::points::{
    JointPlacement, PointFit, PointFitOptions, PointMeasurement, StartPlan, fit_points,
    frf_errors_percent, joint_start, predict_points,
};
use hystid::model::ElementKind;
use hystid::sim::PointSimulator;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The band fitted and judged, Hz.
pub const BAND: (f64, f64) = (4.5, 9.0);
/// The response channels: drive point, wing, payload.
pub const RESPONSES: [&str; 3] = ["acc1", "acc2", "acc3"];
/// Levels 1, 3, 5, 7 fitted; 2, 4, 6 held out.
const FIT: [usize; 4] = [0, 2, 4, 6];
const HELD: [usize; 3] = [1, 3, 5];
/// The modes fitted: the three most prominent peaks of the summed
/// receptances in the band, and modes outside it (Hz) for the rest of the
/// structure: the one rising at the band's top and one each well below and
/// above.
pub const MODES: (usize, &[f64]) = (3, &[3.0, 9.3, 14.0]);

/// One sweep: its file, each response's FRFs in the band (one level) and
/// the sweep law.
pub struct Level {
    pub name: String,
    pub path: PathBuf,
    pub data: Vec<PointMeasurement>,
    pub sweep: SweepFit,
}

/// Levels 1-7 imported into `work` with the force and the three
/// accelerometers, each reduced.
pub fn levels(dir: &Path, work: &Path) -> Vec<Level> {
    let files = [
        "1",
        "2_Validation",
        "3",
        "4_Validation",
        "5",
        "6_Validation",
        "7",
    ];
    let mut args = vec!["-c".to_string(), "force=Force:force".into()];
    for (row, name) in RESPONSES.iter().enumerate() {
        args.extend([
            "-c".into(),
            format!("{name}=Acceleration({}):acceleration", row + 1),
        ]);
    }
    args.extend(["--rate", "variable:Fs", "--excitation", "swept"].map(String::from));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    files
        .iter()
        .map(|l| {
            let name = format!("f16_points_L{}", &l[..1]);
            let source = dir.join(format!("BenchmarkData/F16Data_SineSw_Level{l}.mat"));
            let path = protocols::import(work, &source, &name, &args);
            let (data, sweep) = reduce(&path);
            Level {
                name,
                path,
                data,
                sweep,
            }
        })
        .collect()
}

/// Each response of the recording at `path` reduced as `identify-points`
/// reduces it (swept, 4 periods a hop, every response with the drive
/// point's sweep compensation, so that all share the force's lines) and
/// cut to the band.
fn reduce(path: &Path) -> (Vec<PointMeasurement>, SweepFit) {
    let request = PointsRequest {
        responses: RESPONSES.map(String::from).to_vec(),
        drive: RESPONSES[0].into(),
        joint: "own".into(),
        law: "masing".into(),
        band_hz: Some(format!("{}:{}", BAND.0, BAND.1)),
        modes: MODES.0,
        outside_hz: MODES.1.to_vec(),
        reduction: ReductionOptions {
            excitation: Some(SineTest::Swept),
            hop_periods: 4.0,
            ..ReductionOptions::default()
        },
        ..PointsRequest::default()
    };
    let (frfs, reading) = reduce_at_sensors(path, &request).expect("the sweep reduces");
    let data = frfs
        .iter()
        .enumerate()
        .map(|(p, frf)| {
            PointMeasurement::from_frf(p, frf, Weighting::None).expect("acceleration over force")
        })
        .collect();
    (data, reading.expect("a swept reading").sweep)
}

/// The levels at `which` as one data set.
fn merged(levels: &[Level], which: &[usize]) -> Vec<PointMeasurement> {
    (0..RESPONSES.len())
        .map(|p| PointMeasurement {
            point: p,
            response: levels[which[0]].data[p].response,
            levels: which
                .iter()
                .flat_map(|&i| levels[i].data[p].levels.clone())
                .collect(),
        })
        .collect()
}

/// The joint laws tried.
pub fn laws() -> [&'static str; 3] {
    ["jenkins", "masing", "iwan4"]
}

/// Where the joint is written down.
#[derive(Clone, Copy, Debug)]
pub enum Placement {
    /// Between the wing's and the payload's accelerometers.
    Across,
    /// At a coordinate of its own that no sensor reads, to the ground
    /// ([`JointPlacement::OwnCoordinate`]).
    Unmeasured,
}

impl Placement {
    pub fn all() -> [Placement; 2] {
        [Placement::Across, Placement::Unmeasured]
    }
    pub fn name(self) -> &'static str {
        match self {
            Placement::Across => "across acc2-acc3",
            Placement::Unmeasured => "unmeasured coordinate",
        }
    }
}

/// The fit of `law` at `at` to `data` from its start.
fn fit(data: &[PointMeasurement], law: &str, at: Placement) -> PointFit {
    let plan = StartPlan {
        points: RESPONSES.iter().map(|s| s.to_string()).collect(),
        drive: 0,
        modes: MODES,
        law: ElementKind::from_name(law).expect("a joint law"),
        placement: match at {
            Placement::Across => JointPlacement::Between(1, Some(2)),
            Placement::Unmeasured => JointPlacement::OwnCoordinate,
        },
    };
    let (structure, joint) = joint_start(data, &plan).expect("a start");
    fit_points(
        data,
        &structure,
        0,
        &joint,
        &PointFitOptions::default(),
        &hystid::observe::Silent,
    )
    .expect("the fit runs")
}

/// Each response's FRF error on `data`, one level
/// ([`frf_errors_percent`]).
fn frf_errors(f: &PointFit, data: &[PointMeasurement]) -> Vec<f64> {
    let predicted =
        predict_points(data, &f.structure, 0, &f.joint, &PointFitOptions::default()).unwrap();
    frf_errors_percent(data, &predicted)
        .into_iter()
        .map(|by_level| by_level[0])
        .collect()
}

/// Each response's time-domain error of `level`'s recorded force replayed
/// through the fitted structure: e_RMS over the samples whose instantaneous
/// frequency lies in the band, % of the measured response's RMS there.
fn time_errors(f: &PointFit, level: &Level) -> Vec<f64> {
    let loaded = load_recording(&level.path, ChannelChoice::response(Some("acc1"))).unwrap();
    let rec = &loaded.recording;
    let fs = rec.meta.sample_rate_hz;
    let joint = f.joint.law.build().unwrap();
    let mut sim = PointSimulator::new(&f.structure, 0, f.joint.ends, joint, fs).unwrap();
    let out = sim.run(&rec.channels[0]).unwrap();
    let s = &level.sweep;
    let at = |n: usize| s.f_start_hz + s.rate_hz_per_s * (n as f64 - s.start as f64) / fs;
    let window: Vec<usize> = (s.start..s.end.min(rec.frames()))
        .filter(|&n| (BAND.0..=BAND.1).contains(&at(n)))
        .collect();
    (0..RESPONSES.len())
        .map(|p| {
            let (y, m) = (&out.acceleration[p], &rec.channels[p + 1]);
            let e: f64 = window.iter().map(|&n| (y[n] - m[n]).powi(2)).sum();
            let r: f64 = window.iter().map(|&n| m[n].powi(2)).sum();
            100.0 * (e / r).sqrt()
        })
        .collect()
}

/// `law` fitted on the fitting levels together and each alone, judged on
/// the held-out levels.
pub fn judge(levels: &[Level], law: &str, at: Placement) -> Value {
    let clock = Instant::now();
    let together = fit(&merged(levels, &FIT), law, at);
    let fit_s = clock.elapsed().as_secs_f64();
    eprintln!(
        "{law} {}: rms {:.3} from {:.3}, {} failed, at bounds {:?} (restarted {}), {:?}, {:.0} s",
        at.name(),
        together.residual_rms,
        together.start_rms,
        together.failed_lines,
        together.at_bounds,
        together.restarted,
        together.run.status,
        fit_s
    );
    let held: Vec<Value> = HELD
        .iter()
        .map(|&i| {
            json!({
                "level": levels[i].name,
                "frf_error_percent": frf_errors(&together, &merged(levels, &[i])),
                "time_error_percent": time_errors(&together, &levels[i]),
            })
        })
        .collect();
    let alone: Vec<Value> = FIT
        .iter()
        .map(|&i| {
            let own = merged(levels, &[i]);
            let (t, a) = (
                frf_errors(&together, &own),
                frf_errors(&fit(&own, law, at), &own),
            );
            let ratio: Vec<f64> = t.iter().zip(&a).map(|(t, a)| t / a).collect();
            json!({ "level": levels[i].name, "together": t, "alone": a, "ratio": ratio })
        })
        .collect();
    let mut ratios: Vec<f64> = alone
        .iter()
        .flat_map(|a| a["ratio"].as_array().unwrap().clone())
        .filter_map(|v| v.as_f64())
        .collect();
    ratios.sort_by(f64::total_cmp);
    json!({
        "law": law,
        "placement": at.name(),
        "joint": together.joint.law.parameters().iter().map(|(n, v)| json!({ "name": n, "value": v })).collect::<Vec<_>>(),
        "modes": together.structure.modes,
        "residual_rms": together.residual_rms,
        "start_rms": together.start_rms,
        "failed_lines": together.failed_lines,
        "at_bounds": together.at_bounds,
        "restarted": together.restarted,
        "evaluations": together.run.evaluations,
        "fit_seconds": fit_s,
        "held_out": held,
        "fitting_levels": alone,
        "median_ratio_together_over_alone": ratios[ratios.len() / 2],
        "seconds": clock.elapsed().as_secs_f64(),
    })
}

/// The row's table.
pub fn print(row: &Value) {
    println!(
        "\n{} joint, {}: {}",
        row["law"], row["placement"], row["joint"]
    );
    println!("| level | FRF acc1 / acc2 / acc3 % | time acc1 / acc2 / acc3 % |");
    println!("|---|---|---|");
    let three = |v: &Value| {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| format!("{:.1}", x.as_f64().unwrap()))
            .collect::<Vec<_>>()
            .join(" / ")
    };
    for h in row["held_out"].as_array().unwrap() {
        println!(
            "| {} | {} | {} |",
            h["level"].as_str().unwrap(),
            three(&h["frf_error_percent"]),
            three(&h["time_error_percent"])
        );
    }
    println!(
        "median FRF error together/alone on the fitting levels: {:.2}x; {:.0} s",
        row["median_ratio_together_over_alone"].as_f64().unwrap(),
        row["seconds"].as_f64().unwrap()
    );
}
