//! A whole start for a fit at points, from the data alone: the lowest
//! level's linear modes (the joint stuck), the joint's stick stiffness and
//! slip force anchored to them, and the structure beside the joint.
//!
//! - Across two points, the stick stiffness starts at a tenth of the
//!   stiffest modal stiffness the joint sees, `min_r ω_r²/ψ_r²`: stiff
//!   enough to stick, soft enough to leave every mode its stiffness once
//!   taken out ([`without_joint`]).
//! - At a coordinate of its own ([`with_joint_point`]), only `k_d ψ²` is
//!   seen and `k_d` sets the coordinate's scale: it is the softest modal
//!   stiffness at the drive point among the modes inside the lines,
//!   `min_r ω_r²/φ_r(d)²`, so the coordinate's values are of the sensors'
//!   size.
//! - The slip force is the one at which the stuck joint slips at the
//!   geometric mean of the lowest and the highest level's largest motion
//!   across it, `f_d = k_d √(u_lo u_hi)`; [`super::fit_points`] then tries a
//!   decade either way.

use super::start::{linear_modes_beside, lowest_level, median_force};
use super::{PointJoint, PointMeasurement, problem, with_joint_point, without_joint};
use crate::error::{Error, Result};
use crate::model::{ElementKind, ElementSpec, PointModes, Site};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Where the joint is written down.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum JointPlacement {
    /// Between two measured points (the second `None`: the ground).
    Between(usize, Option<usize>),
    /// From a coordinate that no sensor reads to the ground: the joint
    /// several modes share, its share of each mode free.
    OwnCoordinate,
}

/// What a start needs besides the data.
#[derive(Clone, Debug, PartialEq)]
pub struct StartPlan<'a> {
    /// The measured points' names, in point order.
    pub points: Vec<String>,
    /// The driven point.
    pub drive: usize,
    /// Modes at the peaks, and modes held outside the lines (Hz), as
    /// [`linear_modes_beside`] takes them.
    pub modes: (usize, &'a [f64]),
    /// The joint's law.
    pub law: ElementKind,
    /// Where the joint acts.
    pub placement: JointPlacement,
}

/// The name of the coordinate of [`JointPlacement::OwnCoordinate`].
pub const JOINT_COORDINATE: &str = "joint";

/// The structure beside the joint and the joint, started from `data` as
/// the module docs say.
///
/// Errors: the linear fit's (a point without a sensor, too few lines), a
/// placement naming a point that does not exist, a law that is not a
/// joint.
pub fn joint_start(
    data: &[PointMeasurement],
    plan: &StartPlan,
) -> Result<(PointModes, PointJoint)> {
    let linear = |level| {
        linear_modes_beside(data, plan.points.clone(), plan.drive, plan.modes, level)
            .map(|(modes, _)| modes)
    };
    let stuck = linear(lowest_level(data)?)?;
    let (stuck, ends, kd) = match plan.placement {
        JointPlacement::Between(a, b) => {
            let n = plan.points.len();
            if a >= n || b.is_some_and(|b| b >= n || b == a) {
                return Err(Error::input(
                    "placement",
                    format!("a joint between points {a} and {b:?} of {n}"),
                ));
            }
            let kd = 0.1 * stiffest_seen(&stuck, Site::Across(a, b))?;
            (stuck, (a, b), kd)
        }
        JointPlacement::OwnCoordinate => {
            let soft = linear(highest_level(data)?)?;
            let lines = problem::lines_hz(data);
            let kd = softest_at_drive(&stuck, plan.drive, lines)?;
            let with = with_joint_point(&stuck, &soft, kd, lines, JOINT_COORDINATE)?;
            (with, (plan.points.len(), None), kd)
        }
    };
    let (lo, hi) = motion_across(data, &stuck, plan.drive, ends);
    let fd = kd * (lo * hi).sqrt();
    let law = ElementSpec::joint(plan.law, kd, fd, "law")?;
    let structure = without_joint(&stuck, ends, kd)?;
    Ok((structure, PointJoint { ends, law }))
}

/// The level of the largest median force amplitude.
pub fn highest_level(data: &[PointMeasurement]) -> Result<usize> {
    let first = data
        .first()
        .ok_or_else(|| Error::input("data", "no measurement"))?;
    let median = |l: usize| median_force(&first.levels[l]).unwrap_or(0.0);
    (0..first.levels.len())
        .max_by(|&a, &b| median(a).total_cmp(&median(b)))
        .ok_or_else(|| Error::input("data", "no level"))
}

/// `min_r ω_r²/ψ_r²` over the modes that move `site`.
fn stiffest_seen(stuck: &PointModes, site: Site) -> Result<f64> {
    let k = stuck
        .modes
        .iter()
        .filter(|m| m.at(site).abs() > 0.0)
        .map(|m| (2.0 * PI * m.frequency_hz).powi(2) / m.at(site).powi(2))
        .fold(f64::INFINITY, f64::min);
    finite(k, "no mode moves the joint's ends")
}

/// `min_r ω_r²/φ_r(d)²` over the modes inside `lines_hz`.
fn softest_at_drive(stuck: &PointModes, drive: usize, lines_hz: (f64, f64)) -> Result<f64> {
    let k = stuck
        .modes
        .iter()
        .filter(|m| (lines_hz.0..=lines_hz.1).contains(&m.frequency_hz) && m.shape[drive] != 0.0)
        .map(|m| (2.0 * PI * m.frequency_hz).powi(2) / m.shape[drive].powi(2))
        .fold(f64::INFINITY, f64::min);
    finite(k, "no mode inside the lines moves the drive point")
}

fn finite(k: f64, why: &str) -> Result<f64> {
    if k.is_finite() && k > 0.0 {
        Ok(k)
    } else {
        Err(Error::input("modes", why))
    }
}

/// The smallest and largest over the levels of each level's largest
/// motion across `ends` that the stuck modes predict, `|H_jd(ω)| F`.
fn motion_across(
    data: &[PointMeasurement],
    stuck: &PointModes,
    drive: usize,
    ends: (usize, Option<usize>),
) -> (f64, f64) {
    let across = Site::Across(ends.0, ends.1);
    let largest: Vec<f64> = data[0]
        .levels
        .iter()
        .map(|l| {
            l.lines
                .iter()
                .map(|x| {
                    let w = 2.0 * PI * x.frequency_hz;
                    stuck
                        .receptance_between(across, Site::Point(drive), w)
                        .norm()
                        * x.force_amplitude
                })
                .fold(0.0, f64::max)
        })
        .collect();
    (
        largest.iter().cloned().fold(f64::INFINITY, f64::min),
        largest.iter().cloned().fold(0.0, f64::max),
    )
}
