//! The paper end to end, summarised: `run.json` and `report.md`, which
//! sets the run's estimates beside the paper's Table 3.1.

use super::identify::FitReport;
use super::simulate::SimulateSummary;
use crate::diagnose::Diagnosis;
use crate::fit::FitResult;
use crate::model::Role;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

/// `run.json`.
#[derive(Serialize)]
pub struct RunSummary<'a> {
    /// `run`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// The virtual test.
    pub simulate: &'a SimulateSummary,
    /// The fit.
    pub fit: &'a FitReport,
    /// The diagnosis, unless skipped.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub diagnosis: Option<DiagnosisSummary>,
    /// Wall time, s.
    pub seconds: f64,
    /// Files written.
    pub files: Vec<PathBuf>,
}

/// The diagnosis in `run.json` (fields in the order JSON objects of the
/// earlier `run.json` had: alphabetical).
#[derive(Serialize)]
pub struct DiagnosisSummary {
    /// The baseline's relative error.
    pub baseline_error_relative: f64,
    /// The final model's `χ²` per degree of freedom.
    pub final_chi2_per_dof: f64,
    /// The final model's relative error.
    pub final_error_relative: f64,
    /// Wall time, s.
    pub seconds: f64,
    /// The effects added.
    pub selected: Vec<&'static str>,
}

impl DiagnosisSummary {
    /// The summary of `d`, diagnosed in `seconds`.
    pub fn of(d: &Diagnosis, seconds: f64) -> Self {
        DiagnosisSummary {
            baseline_error_relative: d.baseline.error_relative,
            final_chi2_per_dof: d.final_fit.chi2_per_dof,
            final_error_relative: d.final_fit.error_relative,
            seconds,
            selected: d.selected.iter().map(|s| s.effect.name()).collect(),
        }
    }
}

/// The diagnosis section of `report.md`.
pub fn diagnosis_markdown(d: &Diagnosis, seconds: f64) -> String {
    format!(
        "## Diagnosis: what the model lacks\n\n{}\n\n(all candidates refitted in {seconds:.1} s; details in `diagnosis.md`)\n\n![residual before and after](residual.png)\n",
        d.explanation
    )
}

fn fmt_param(fit: &FitResult, name: &str) -> String {
    match fit.parameters.get(name) {
        Some(e) if e.ci95[1].is_infinite() => {
            format!("{:.4} (≥ {:.3}, not identifiable)", e.value, e.ci95[0])
        }
        Some(e) => format!("{:.4e} [{:.4e}, {:.4e}]", e.value, e.ci95[0], e.ci95[1]),
        None => "–".into(),
    }
}

/// `report.md` up to the diagnosis: the paper's Table 3.1 beside this
/// run's result.
pub fn report_markdown(sim: &SimulateSummary, report: &FitReport) -> String {
    let fit = &report.fit;
    let reference = report.reference.as_ref();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# hystid run: parameter estimation of a hysteresis element (Magnevall, Josefsson & Ahlin)\n"
    );
    let _ = writeln!(
        s,
        "Virtual stepped-sine test: {} levels × {} frequencies, {:.0} Hz sampling, {:.1} % response noise (measured, RMS); {} frames in {:.2} s. \
         Fitted element: `{}` by harmonic balance and Nelder–Mead on eq. (9), {} evaluations in {:.2} s.\n",
        sim.levels,
        sim.dwells / sim.levels.max(1),
        sim.sample_rate_hz,
        100.0 * sim.mean_noise_ratio,
        sim.frames,
        sim.seconds,
        fit.element.name(),
        fit.effort.evaluations,
        fit.effort.seconds
    );
    let _ = writeln!(s, "## Table 3.1, the paper and this run\n");
    let _ = writeln!(s, "| | Fd [N] | kd [N/m] | N |");
    let _ = writeln!(s, "|---|---|---|---|");
    let _ = writeln!(s, "| Reference parameters (paper) | 246.048 | 2.4e7 | |");
    let _ = writeln!(
        s,
        "| Estimated parameters (paper) | 242.05 (−1.6 %) | 2.33e7 (−2.9 %) | 22.55 |"
    );
    if let Some(r) = reference {
        // the paper's columns by what each parameter is to the law: its slip
        // force, its stick stiffness, and its shape (none for a Jenkins
        // element, the N → ∞ limit)
        let d = r.description();
        let shape: Vec<String> = d
            .parameters
            .iter()
            .zip(r.parameters())
            .filter(|(p, _)| p.role == Role::Other)
            .map(|(_, (_, v))| format!("{v}"))
            .collect();
        let _ = writeln!(
            s,
            "| Reference element of this run (`{}`) | {} | {:e} | {} |",
            d.name,
            r.value_of(Role::SlipForce).unwrap_or(f64::NAN),
            r.stick_stiffness(),
            if shape.is_empty() {
                "∞ (no curvature: a Jenkins element)".to_string()
            } else {
                shape.join(", ")
            }
        );
    }
    let pct = |name: &str| {
        report
            .comparison
            .iter()
            .find(|c| c.parameter == name)
            .map_or(String::new(), |c| {
                format!(" ({:+.2} %)", 100.0 * c.relative_error)
            })
    };
    // the columns by what each parameter is to the fitted law
    let law = fit.element.description();
    let named = |role: Role| -> Vec<&str> {
        law.parameters
            .iter()
            .filter(|p| p.role == role)
            .map(|p| p.name)
            .collect()
    };
    let column = |role: Role| -> String {
        let cells: Vec<String> = named(role)
            .into_iter()
            .map(|n| format!("{}{}", fmt_param(fit, n), pct(n)))
            .collect();
        if cells.is_empty() {
            "–".to_string()
        } else {
            cells.join(", ")
        }
    };
    let _ = writeln!(
        s,
        "| **Estimated (hystid)**, 95 % interval | {} | {} | {} |\n",
        column(Role::SlipForce),
        column(Role::StickStiffness),
        column(Role::Other)
    );
    let _ = writeln!(
        s,
        "Relative FRF error ‖H_meas − H_model‖/‖H_meas‖ = {:.4} (χ²/dof = {:.3} with the measured standard errors). \
         Linear system from the largest level: m = {:.5} kg, c = {:.4} N s/m, k = {:.6e} N/m; after the fit: \
         m = {:.5} kg, c = {:.4} N s/m, k = {:.6e} N/m. Stick stiffness from the smallest level k_low = {:.6e} N/m, \
         initial kd = k_low − k = {:.4e} N/m.\n",
        fit.error.relative,
        fit.error.chi2_per_dof,
        fit.linear.underlying.mass,
        fit.linear.underlying.damping,
        fit.linear.underlying.stiffness,
        fit.linear.mass,
        fit.linear.damping,
        fit.linear.stiffness,
        fit.linear.stick.stiffness,
        fit.linear.kd_initial
    );
    if let Some(n) = named(Role::Other)
        .first()
        .and_then(|n| fit.parameters.get(*n))
        .and_then(|e| e.note.as_ref())
    {
        let _ = writeln!(
            s,
            "On N: {n}. The paper's N = 22.55 most likely lies on the same flat valley: eq. (10) tends to a Jenkins element as N → ∞ and the cost hardly changes once N is large, so bias and noise in a simulated measurement can settle the optimum at a finite N.\n"
        );
    }
    for note in &fit.notes {
        let _ = writeln!(s, "Note: {note}\n");
    }
    let _ = writeln!(s, "## Figures\n");
    let _ = writeln!(
        s,
        "Measured nonlinear FRFs (paper Fig. 3.4 right):\n\n![FRFs](frf.png)\n"
    );
    let _ = writeln!(
        s,
        "Measured (markers) against the fitted model (lines):\n\n![fit](fit_frf.png)\n"
    );
    let _ = writeln!(
        s,
        "Fitted hysteresis loops over the reference element's (paper Fig. 3.4 left):\n\n![loops](loops.png)\n"
    );
    let _ = writeln!(
        s,
        "Optimiser convergence:\n\n![convergence](convergence.png)\n"
    );
    s
}
