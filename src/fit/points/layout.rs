//! The optimiser's coordinates of a structure at points and its joint:
//! `ln f_r`, `ln ζ_r` per mode, then each shape value over its start's
//! magnitude (signed), then the joint's parameters' logarithms.

use crate::error::{Error, Result};
use crate::model::{ElementSpec, PointModes, ShapedMode};

/// The damping ratios a mode may take.
const ZETA_BOUNDS: (f64, f64) = (1e-4, 0.5);
/// How far (in `ln`) a mode's frequency may move from its start: a factor
/// 1.25 either way, so that a small mode is not traded for a second copy of a
/// large one beside it.
const FREQUENCY_RANGE: f64 = 0.223_143_551_314_209_7;
/// How far (in `ln`) a joint parameter may move from its start: six decades.
const JOINT_RANGE: f64 = 13.815_510_557_964_274;

/// Where each model number sits in `θ`.
#[derive(Clone, Debug)]
pub(super) struct Layout {
    points: Vec<String>,
    modes: usize,
    /// `|φ_r,0(p)|` (or the mode's largest where that is zero), mode-major.
    scales: Vec<f64>,
    /// `ln f_r` at the start.
    frequencies: Vec<f64>,
    /// How far each `ln f_r` may move from its start.
    frequency_ranges: Vec<f64>,
    /// Each mode's lowest `ln ζ_r`.
    zeta_floors: Vec<f64>,
    /// The joint's start, if there is a joint.
    joint: Option<ElementSpec>,
}

impl Layout {
    /// The layout of `structure` (its values the scales' start) and
    /// `joint`.
    pub(super) fn new(structure: &PointModes, joint: Option<&ElementSpec>) -> Result<Layout> {
        structure.validate()?;
        let mut scales = Vec::new();
        for m in &structure.modes {
            let largest = m.shape.iter().fold(0.0, |a: f64, v| a.max(v.abs()));
            if largest == 0.0 {
                return Err(Error::model("shape", "a mode's shape is zero everywhere"));
            }
            scales.extend(
                m.shape
                    .iter()
                    .map(|v| if *v != 0.0 { v.abs() } else { largest }),
            );
        }
        if let Some(j) = joint
            && let Some((name, v)) = j
                .parameters()
                .into_iter()
                .find(|(_, v)| *v <= 0.0 || !v.is_finite())
        {
            return Err(Error::model(
                name,
                format!("a fitted joint parameter must be positive, got {v}"),
            ));
        }
        Ok(Layout {
            points: structure.points.clone(),
            modes: structure.modes.len(),
            scales,
            frequencies: structure
                .modes
                .iter()
                .map(|m| m.frequency_hz.ln())
                .collect(),
            frequency_ranges: vec![FREQUENCY_RANGE; structure.modes.len()],
            zeta_floors: vec![ZETA_BOUNDS.0.ln(); structure.modes.len()],
            joint: joint.copied(),
        })
    }

    /// Modes starting outside `lines_hz` are seen only through what they
    /// leave inside: their damping ratios are held at `floor` or more.
    pub(super) fn damped_outside(mut self, lines_hz: (f64, f64), floor: f64) -> Layout {
        for (r, f) in self.frequencies.iter().enumerate() {
            if !(lines_hz.0.ln()..=lines_hz.1.ln()).contains(f) {
                self.zeta_floors[r] = floor.ln();
            }
        }
        self
    }

    /// Number of points.
    pub(super) fn points(&self) -> usize {
        self.points.len()
    }

    fn shapes_at(&self) -> usize {
        2 * self.modes
    }

    fn joint_at_index(&self) -> usize {
        self.shapes_at() + self.scales.len()
    }

    /// `θ` of `structure` and `joint` (which must have this layout's
    /// sizes).
    pub(super) fn theta_of(&self, structure: &PointModes, joint: Option<&ElementSpec>) -> Vec<f64> {
        let mut theta: Vec<f64> = structure
            .modes
            .iter()
            .flat_map(|m| [m.frequency_hz.ln(), m.damping_ratio.ln()])
            .collect();
        let shapes = structure.modes.iter().flat_map(|m| m.shape.iter());
        theta.extend(shapes.zip(&self.scales).map(|(v, s)| v / s));
        if let Some(j) = joint {
            theta.extend(j.parameters().iter().map(|(_, v)| v.ln()));
        }
        theta
    }

    /// The structure at `theta` and the distance (in `ln`) of its damping
    /// ratios and frequencies outside their bounds, those held at the
    /// bound.
    pub(super) fn structure_at(&self, theta: &[f64]) -> (PointModes, f64) {
        let n = self.points.len();
        let mut outside = 0.0;
        let modes = (0..self.modes)
            .map(|r| {
                let lz = theta[2 * r + 1];
                let (lo, hi) = (self.zeta_floors[r], ZETA_BOUNDS.1.ln());
                outside += (lo - lz).max(0.0) + (lz - hi).max(0.0);
                let (lf, c) = (theta[2 * r], self.frequencies[r]);
                let range = self.frequency_ranges[r];
                outside += ((lf - c).abs() - range).max(0.0);
                let at = self.shapes_at() + r * n;
                ShapedMode {
                    frequency_hz: lf.clamp(c - range, c + range).exp(),
                    damping_ratio: lz.clamp(lo, hi).exp(),
                    shape: (0..n)
                        .map(|p| theta[at + p] * self.scales[r * n + p])
                        .collect(),
                }
            })
            .collect();
        (
            PointModes {
                points: self.points.clone(),
                modes,
            },
            outside,
        )
    }

    /// The joint at `theta` and the distance (in `ln`) of its parameters
    /// beyond six decades from their start, those held there; `None` without
    /// a joint.
    pub(super) fn joint_at(&self, theta: &[f64]) -> Option<(ElementSpec, f64)> {
        let start = self.joint?;
        let at = self.joint_at_index();
        let mut outside = 0.0;
        let values: Vec<f64> = start
            .parameters()
            .iter()
            .enumerate()
            .map(|(i, (_, v0))| {
                let (t, c) = (theta[at + i], v0.ln());
                outside += ((t - c).abs() - JOINT_RANGE).max(0.0);
                t.clamp(c - JOINT_RANGE, c + JOINT_RANGE).exp()
            })
            .collect();
        Some((start.with_parameters(&values), outside))
    }
}
