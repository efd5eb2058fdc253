//! The optimiser's coordinates of a structure at points and its joint:
//! `ln f_r`, `ln ζ_r` per mode, then each shape value over its start's
//! magnitude (signed), then the joint's free parameters in the coordinates
//! and bounds the one-point fit gives them ([`ParameterSet::for_law`]).

use crate::error::{Error, Result};
use crate::fit::params::ParameterSet;
use crate::model::{ElementSpec, PointModes, ShapedMode};

/// The damping ratios a mode may take.
const ZETA_BOUNDS: (f64, f64) = (1e-4, 0.5);
/// How far (in `ln`) a mode's frequency may move from its start: a factor
/// 1.25 either way, so that a small mode is not traded for a second copy of a
/// large one beside it.
const FREQUENCY_RANGE: f64 = 0.223_143_551_314_209_7;

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
    /// The joint's start and its free parameters, if there is a joint.
    joint: Option<(ElementSpec, ParameterSet)>,
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
        if let Some(j) = joint {
            j.build()?;
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
            joint: joint.map(|j| (*j, ParameterSet::for_law(j))),
        })
    }

    /// The layout with the joint's parameters named in `held` held at
    /// their start, no longer free.
    pub(super) fn holding(mut self, held: &[String]) -> Layout {
        if let Some((_, free)) = &mut self.joint {
            free.parameters
                .retain(|p| !held.iter().any(|h| h == p.target_name()));
        }
        self
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
        if let (Some(j), Some((_, free))) = (joint, &self.joint) {
            let value = |name: &str| {
                j.parameters()
                    .into_iter()
                    .find(|(n, _)| *n == name)
                    .map_or(f64::NAN, |(_, v)| v)
            };
            theta.extend(
                free.parameters
                    .iter()
                    .map(|p| p.theta(value(p.target_name()))),
            );
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

    /// The joint at `theta` (its held parameters at their start) and the
    /// distance (in `θ`) of its free parameters outside their bounds, those
    /// held at the bound; `None` without a joint.
    pub(super) fn joint_at(&self, theta: &[f64]) -> Option<(ElementSpec, f64)> {
        let (start, free) = self.joint.as_ref()?;
        let at = self.joint_at_index();
        let mut outside = 0.0;
        let values: Vec<f64> = start
            .parameters()
            .iter()
            .map(|(name, v0)| {
                let Some(i) = free
                    .parameters
                    .iter()
                    .position(|p| p.target_name() == *name)
                else {
                    return *v0;
                };
                let (v, o) = free.parameters[i].clamped(theta[at + i]);
                outside += o;
                v
            })
            .collect();
        Some((start.with_parameters(&values), outside))
    }

    /// The names of the joint's free parameters at `theta` that lie within
    /// 1 % of a bound of their range ([`ParameterSet::at_bounds`]).
    pub(super) fn joint_at_bounds(&self, theta: &[f64]) -> Vec<String> {
        let Some((_, free)) = &self.joint else {
            return Vec::new();
        };
        let at = self.joint_at_index();
        let values: Vec<f64> = (free.parameters.iter().enumerate())
            .map(|(i, p)| p.clamped(theta[at + i]).0)
            .collect();
        (free.parameters.iter().zip(free.at_bounds(&values)))
            .filter(|(_, at_bound)| *at_bound)
            .map(|(p, _)| p.target_name().to_string())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_modes() -> PointModes {
        let mode = |f: f64| ShapedMode {
            frequency_hz: f,
            damping_ratio: 0.01,
            shape: vec![0.5, -0.25],
        };
        PointModes {
            points: vec!["a".into(), "b".into()],
            modes: vec![mode(6.65), mode(7.32)],
        }
    }

    /// Every law of the registry a joint may take goes through `θ` and
    /// back unchanged, Iwan's negative `χ` and Masing's `N` (fitted as
    /// `1/N`) included.
    #[test]
    fn a_joints_parameters_go_through_theta_and_back() {
        let s = two_modes();
        for law in [
            ElementSpec::Jenkins { kd: 4.0e4, fd: 4.0 },
            ElementSpec::Masing {
                kd: 4.0e4,
                fd: 4.0,
                n: 2.5,
            },
            ElementSpec::Iwan4 {
                fs: 4.0,
                kt: 4.0e4,
                chi: -0.5,
                beta: 0.2,
            },
        ] {
            let layout = Layout::new(&s, Some(&law)).expect("a valid joint");
            let mut theta = layout.theta_of(&s, Some(&law));
            let (back, outside) = layout.joint_at(&theta).expect("a joint");
            assert_eq!(outside, 0.0, "{law:?}");
            assert!(layout.joint_at_bounds(&theta).is_empty(), "{law:?}");
            // the last free parameter pushed far past either end of its
            // range is reported at a bound, and it alone
            let last = theta.len() - 1;
            let free = &layout.joint.as_ref().unwrap().1.parameters;
            let name = free.last().unwrap().target_name().to_string();
            for far in [-1e3, 1e3] {
                theta[last] = far;
                assert_eq!(
                    layout.joint_at_bounds(&theta),
                    vec![name.clone()],
                    "{law:?}"
                );
            }
            theta[last] = layout.theta_of(&s, Some(&law))[last];
            for ((n, a), (_, b)) in law.parameters().into_iter().zip(back.parameters()) {
                assert!((a - b).abs() <= 1e-12 * a.abs(), "{n}: {a} -> {b}");
            }
        }
    }
}
