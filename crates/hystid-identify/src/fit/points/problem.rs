//! The fits' objectives: the structure with its joint solved by harmonic
//! balance at every line ([`JointProblem`]), and the linear modes alone at
//! one level ([`LinearProblem`]).

use super::layout::Layout;
use super::{PointFitOptions, PointJoint, PointLine, PointMeasurement, predict_points};
use crate::error::{Error, Result};
use crate::fit::optimise::Objective;
use crate::hb::HbOptions;
use crate::model::{PointModes, Site};
use num_complex::Complex64;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The harmonic-balance options of a fit.
pub(super) fn hb_options(options: &PointFitOptions) -> HbOptions {
    HbOptions {
        samples_per_period: options.samples_per_period,
        ..HbOptions::with_harmonics(options.harmonics.clone())
    }
}

/// Checks that every measurement is at a point of the structure and has the
/// first one's levels and lines (the same drive, read by several sensors);
/// returns the lines per level.
pub(super) fn check_lines(data: &[PointMeasurement], points: usize) -> Result<Vec<usize>> {
    let first = data
        .first()
        .ok_or_else(|| Error::input("data", "no measurement to fit"))?;
    let shape: Vec<usize> = first.levels.iter().map(|l| l.lines.len()).collect();
    for (i, m) in data.iter().enumerate() {
        if m.point >= points {
            return Err(Error::input(
                format!("data[{i}].point"),
                format!("point {} of a structure of {points}", m.point),
            ));
        }
        let same = m.levels.len() == shape.len()
            && m.levels.iter().zip(&first.levels).all(|(l, f)| {
                l.lines.len() == f.lines.len()
                    && l.lines.iter().zip(&f.lines).all(|(a, b)| {
                        (a.frequency_hz / b.frequency_hz - 1.0).abs() < 1e-9
                            && (a.force_amplitude / b.force_amplitude - 1.0).abs() < 1e-6
                            && a.weight > 0.0
                            && a.weight.is_finite()
                    })
            });
        if !same {
            return Err(Error::input(
                format!("data[{i}]"),
                "needs the first measurement's levels and lines (frequencies, forces) \
                 and positive weights",
            ));
        }
    }
    Ok(shape)
}

/// The lowest and highest line of every level of `data`, Hz.
pub(super) fn lines_hz(data: &[PointMeasurement]) -> (f64, f64) {
    let all = data
        .iter()
        .flat_map(|m| &m.levels)
        .flat_map(|l| &l.lines)
        .map(|l| l.frequency_hz);
    all.fold((f64::INFINITY, 0.0), |(lo, hi), f| (lo.min(f), hi.max(f)))
}

/// The residual pair of one line: `(predicted − measured)/weight`; a line
/// not solved counts as twice the measurement, worse than predicting
/// nothing, so that an optimiser steps back from it.
fn push_pair(r: &mut Vec<f64>, predicted: Option<Complex64>, line: &PointLine) {
    let d = predicted.map_or(2.0 * line.h, |p| p - line.h) / line.weight;
    r.extend([d.re, d.im]);
}

/// The penalty row: the distance outside the bounds at ten times the
/// residuals' RMS per unit, scaled to their count.
fn with_penalty(mut r: Vec<f64>, outside: f64) -> Vec<f64> {
    let scale = (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt();
    r.push(outside * 10.0 * scale * (r.len() as f64).sqrt());
    r
}

fn rms(r: &[f64]) -> f64 {
    (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
}

/// The structure and its joint against every level.
pub(super) struct JointProblem<'a> {
    data: &'a [PointMeasurement],
    layout: &'a Layout,
    drive: usize,
    ends: (usize, Option<usize>),
    options: PointFitOptions,
    evaluations: AtomicUsize,
    /// Asked before each evaluation whether the work is to stop.
    observer: &'a dyn crate::observe::Observer,
}

impl<'a> JointProblem<'a> {
    /// The same problem, asking `observer` before each evaluation whether
    /// the work is to stop ([`Error::Cancelled`] if so).
    pub(super) fn observed(self, observer: &'a dyn crate::observe::Observer) -> Self {
        JointProblem { observer, ..self }
    }

    pub(super) fn new(
        data: &'a [PointMeasurement],
        layout: &'a Layout,
        drive: usize,
        ends: (usize, Option<usize>),
        options: &PointFitOptions,
    ) -> Result<JointProblem<'a>> {
        let points = layout.points();
        check_lines(data, points)?;
        if drive >= points || ends.0 >= points || ends.1.is_some_and(|b| b >= points || b == ends.0)
        {
            return Err(Error::input(
                "points",
                "the drive and the joint's ends must be points of the structure, \
                 the ends two distinct ones",
            ));
        }
        hb_options(options).validate()?;
        Ok(JointProblem {
            data,
            layout,
            drive,
            ends,
            options: options.clone(),
            evaluations: AtomicUsize::new(0),
            observer: &crate::observe::Silent,
        })
    }

    /// The data rows, the distance outside the bounds and the lines not
    /// solved.
    fn rows(&self, theta: &[f64]) -> Result<(Vec<f64>, f64, usize)> {
        let (structure, mut outside) = self.layout.structure_at(theta);
        let (law, o) = self.layout.joint_at(theta).expect("a joint");
        outside += o;
        let joint = PointJoint {
            ends: self.ends,
            law,
        };
        let predicted =
            match predict_points(self.data, &structure, self.drive, &joint, &self.options) {
                Ok(p) => Some(p),
                Err(Error::InvalidModel { .. }) => None,
                Err(e) => return Err(e),
            };
        let mut r = Vec::new();
        let mut failed = 0;
        for (level, lines) in self.data[0].levels.iter().enumerate() {
            for line in 0..lines.lines.len() {
                let at = predicted.as_ref().and_then(|p| p[level][line].as_ref());
                failed += usize::from(at.is_none());
                for (m, d) in self.data.iter().enumerate() {
                    push_pair(&mut r, at.map(|h| h[m]), &d.levels[level].lines[line]);
                }
            }
        }
        Ok((r, outside, failed))
    }

    /// The RMS of the data rows at `theta` and the lines not solved.
    pub(super) fn rms(&self, theta: &[f64]) -> Result<(f64, usize)> {
        let (r, _, failed) = self.rows(theta)?;
        Ok((rms(&r), failed))
    }
}

impl Objective for JointProblem<'_> {
    fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>> {
        if self.observer.cancelled() {
            return Err(Error::Cancelled);
        }
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let (r, outside, _) = self.rows(theta)?;
        Ok(with_penalty(r, outside))
    }
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        Ok(self.residuals(theta)?.iter().map(|v| v * v).sum())
    }
    fn evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }
}

/// The linear modes alone against one level.
pub(super) struct LinearProblem<'a> {
    pub(super) data: &'a [PointMeasurement],
    pub(super) level: usize,
    pub(super) layout: &'a Layout,
    pub(super) drive: usize,
    pub(super) evaluations: AtomicUsize,
}

impl LinearProblem<'_> {
    /// The data rows at the structure `s`.
    pub(super) fn rows_of(&self, s: &PointModes) -> Vec<f64> {
        let mut r = Vec::new();
        for (i, line) in self.data[0].levels[self.level].lines.iter().enumerate() {
            let w = 2.0 * std::f64::consts::PI * line.frequency_hz;
            for m in self.data {
                let h = s.receptance_between(Site::Point(m.point), Site::Point(self.drive), w);
                let at = &m.levels[self.level].lines[i];
                push_pair(&mut r, Some(h * m.response.from_displacement(w)), at);
            }
        }
        r
    }

    /// The RMS of the data rows at `theta`.
    pub(super) fn rms(&self, theta: &[f64]) -> f64 {
        rms(&self.rows_of(&self.layout.structure_at(theta).0))
    }
}

impl Objective for LinearProblem<'_> {
    fn residuals(&self, theta: &[f64]) -> Result<Vec<f64>> {
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        let (s, outside) = self.layout.structure_at(theta);
        Ok(with_penalty(self.rows_of(&s), outside))
    }
    fn cost(&self, theta: &[f64]) -> Result<f64> {
        Ok(self.residuals(theta)?.iter().map(|v| v * v).sum())
    }
    fn evaluations(&self) -> usize {
        self.evaluations.load(Ordering::Relaxed)
    }
}
