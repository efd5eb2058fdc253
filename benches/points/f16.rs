//! The F-16 at three points: import, reduction, fits and judgements.

use super::protocols;
use hystid::analysis::recording::{
    ChannelChoice, Compensation, ReductionOptions, SineTest, load_recording, reduce_path,
};
use hystid::extract::SweepFit;
use hystid::fit::points::{
    PointFit, PointFitOptions, PointJoint, PointMeasurement, fit_points, linear_modes_beside,
    lowest_level, predict_points, without_joint,
};
use hystid::model::{ElementSpec, PointModes, Site};
use hystid::sim::PointSimulator;
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The band fitted and judged, Hz.
pub const BAND: (f64, f64) = (4.5, 9.0);
/// The response channels: drive point, wing, payload.
pub const RESPONSES: [&str; 3] = ["acc1", "acc2", "acc3"];
/// The joint's ends: wing and payload.
const ENDS: (usize, Option<usize>) = (1, Some(2));
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

/// Each response of the recording at `path` reduced (swept, 4 periods a
/// hop, every response with the sweep compensation the wing's reduction
/// chooses, so that all share the force's lines) and cut to the band.
fn reduce(path: &Path) -> (Vec<PointMeasurement>, SweepFit) {
    let mut options = ReductionOptions {
        excitation: Some(SineTest::Swept),
        hop_periods: 4.0,
        ..ReductionOptions::default()
    };
    let one = |name: &str, options: &ReductionOptions| {
        reduce_path(
            path,
            ChannelChoice::response(Some(name)),
            options,
            &hystid::observe::Silent,
        )
        .expect("the sweep reduces")
    };
    let red = one(RESPONSES[1], &options);
    let (wing, reading) = (red.frf, red.sweep.expect("a swept reading"));
    if let Some(c) = reading.compensation_s {
        options.compensation = Compensation::Seconds(c);
    }
    let data = RESPONSES
        .iter()
        .enumerate()
        .map(|(p, name)| {
            let mut frf = if p == 1 {
                wing.clone()
            } else {
                one(name, &options).frf
            };
            for l in &mut frf.levels {
                l.points
                    .retain(|x| (BAND.0..=BAND.1).contains(&x.frequency_hz));
            }
            PointMeasurement::from_frf(p, &frf).expect("acceleration over force")
        })
        .collect();
    (data, reading.sweep)
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
pub fn laws() -> [&'static str; 2] {
    ["jenkins", "masing"]
}

/// The start: the lowest level's stuck modes, a stick stiffness a tenth of
/// the stiffest modal stiffness the joint sees (`ω_r²/ψ_r²`), a slip force
/// that slips at the geometric mean of the lowest and highest levels'
/// largest relative motion across the joint.
fn start(data: &[PointMeasurement], law: &str) -> (PointModes, PointJoint) {
    let lowest = lowest_level(data).expect("levels");
    let points = RESPONSES.iter().map(|s| s.to_string()).collect();
    let (stuck, _) = linear_modes_beside(data, points, 0, MODES, lowest).expect("linear modes");
    let kd = 0.1
        * stuck
            .modes
            .iter()
            .map(|m| (2.0 * PI * m.frequency_hz).powi(2) / m.at(Site::Across(1, Some(2))).powi(2))
            .fold(f64::INFINITY, f64::min);
    let motion = |l: &hystid::fit::points::PointLevel, b: &hystid::fit::points::PointLevel| {
        l.lines
            .iter()
            .zip(&b.lines)
            .map(|(x, y)| {
                let w2 = (2.0 * PI * x.frequency_hz).powi(2);
                (x.h - y.h).norm() * x.force_amplitude / w2
            })
            .fold(0.0, f64::max)
    };
    let a: Vec<f64> = (0..data[1].levels.len())
        .map(|l| motion(&data[1].levels[l], &data[2].levels[l]))
        .collect();
    let (lo, hi) = (
        a.iter().cloned().fold(f64::INFINITY, f64::min),
        a.iter().cloned().fold(0.0, f64::max),
    );
    let fd = kd * (lo * hi).sqrt();
    let law = match law {
        "jenkins" => ElementSpec::Jenkins { kd, fd },
        _ => ElementSpec::Masing { kd, fd, n: 2.0 },
    };
    let structure = without_joint(&stuck, ENDS, kd).expect("the structure beside the joint");
    (structure, PointJoint { ends: ENDS, law })
}

/// The fit of `law` to `data` from its start.
fn fit(data: &[PointMeasurement], law: &str) -> PointFit {
    let (structure, joint) = start(data, law);
    fit_points(data, &structure, 0, &joint, &PointFitOptions::default()).expect("the fit runs")
}

/// Each response's FRF error over `data`'s lines: RMS `|H_pred − H_meas|`
/// over RMS `|H_meas|`, % (a line not solved predicts nothing).
fn frf_errors(f: &PointFit, data: &[PointMeasurement]) -> Vec<f64> {
    let predicted =
        predict_points(data, &f.structure, 0, &f.joint, &PointFitOptions::default()).unwrap();
    data.iter()
        .enumerate()
        .map(|(m, d)| {
            let (mut e, mut s) = (0.0, 0.0);
            for (l, level) in d.levels.iter().enumerate() {
                for (i, line) in level.lines.iter().enumerate() {
                    let p = predicted[l][i].as_ref().map_or(0.0.into(), |h| h[m]);
                    e += (p - line.h).norm_sqr();
                    s += line.h.norm_sqr();
                }
            }
            100.0 * (e / s).sqrt()
        })
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
    let mut sim = PointSimulator::new(&f.structure, 0, ENDS, joint, fs).unwrap();
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
pub fn judge(levels: &[Level], law: &str) -> Value {
    let clock = Instant::now();
    let together = fit(&merged(levels, &FIT), law);
    let fit_s = clock.elapsed().as_secs_f64();
    eprintln!(
        "{law}: rms {:.3} from {:.3}, {} failed, {:?}, {:.0} s",
        together.residual_rms,
        together.start_rms,
        together.failed_lines,
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
                frf_errors(&fit(&own, law), &own),
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
        "joint": together.joint.law.parameters().iter().map(|(n, v)| json!({ "name": n, "value": v })).collect::<Vec<_>>(),
        "modes": together.structure.modes,
        "residual_rms": together.residual_rms,
        "start_rms": together.start_rms,
        "failed_lines": together.failed_lines,
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
    println!("\n{} joint: {}", row["law"], row["joint"]);
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
