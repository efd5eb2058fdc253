//! Recordings on disk into nonlinear FRFs: load (MCAP run file or WAV +
//! JSON, with the test definition a virtual test recorded), choose the
//! response channel, reduce (stepped or swept sine), combine several.

mod load;
mod reduce;
mod replay;

pub use load::{
    ChannelChoice, HeldRecording, Loaded, channel_names, load_held_reference_and_response,
    load_recording, load_reference_and_response, load_time_record, response_channel,
    response_channel_name, stated_excitation,
};
pub(crate) use reduce::multisine_period;
pub use reduce::{
    Compensation, MULTISINE_LINES, Reduced, ReductionOptions, SineTest, SweptReading, coil_of_path,
    combine_recordings, excitation_of, max_harmonic, quality_notes, reduce, reduce_path,
    reduce_recordings, stepped_options, sweep_options,
};
pub use replay::{ReplayReduction, band_limited};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;
    use crate::harmonics::Quantity;
    use crate::record::{Excitation as Sidecar, ExcitationKind, Step};

    /// Arrays as a recording: a stepped sine through the linear SDOF is
    /// reduced on its steps; bad arrays are errors that name them.
    #[test]
    fn signals_in_memory_reduce_as_a_recording() {
        let model = crate::model::Model::new(
            crate::model::ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            Vec::new(),
        )
        .unwrap();
        let fs = 10_000.0;
        let (f, n) = (200.0, 20_000);
        let force: Vec<f64> = (0..n)
            .map(|i| 100.0 * (2.0 * std::f64::consts::PI * f * i as f64 / fs).cos())
            .collect();
        let x = crate::sim::simulate(
            &model,
            &force,
            fs,
            crate::sim::Output::Displacement,
            &crate::observe::Silent,
        )
        .unwrap();
        let steps = vec![Step {
            frequency_hz: f,
            level: 100.0,
            start: 0,
            settle: 15_000,
            length: n,
        }];
        let excitation = Sidecar {
            kind: ExcitationKind::SteppedSine,
            steps,
            sweep: None,
        };
        let loaded = Loaded::from_signals(
            force.clone(),
            Quantity::Force,
            x.clone(),
            Quantity::Displacement,
            fs,
            excitation.clone(),
        )
        .unwrap();
        let red = reduce(
            &loaded,
            &ReductionOptions::default(),
            &crate::observe::Silent,
        )
        .unwrap();
        assert_eq!(red.response_name, "displacement");
        let p = &red.frf.levels[0].points[0];
        let w = crate::harmonics::omega(f);
        let exact =
            model.linear.frf(Quantity::Displacement, w) * crate::harmonics::sinc(f / fs).powi(2);
        // the ramp-invariant filter's steady state, to its aliases (< 1e-6)
        assert!(
            (p.h[1] / exact - 1.0).norm() < 1e-6,
            "{} vs {exact}",
            p.h[1]
        );
        let err = |r: Result<Loaded>| r.err().unwrap().to_string();
        let mk = |a: Vec<f64>, qa, b: Vec<f64>, qb, fs| {
            Loaded::from_signals(a, qa, b, qb, fs, excitation.clone())
        };
        let d = Quantity::Displacement;
        assert!(
            err(mk(force.clone(), Quantity::Force, x[1..].to_vec(), d, fs))
                .contains("same, non-zero length")
        );
        assert!(err(mk(x.clone(), d, x.clone(), d, fs)).contains("a force or a voltage"));
        assert!(
            err(mk(
                force.clone(),
                Quantity::Force,
                force.clone(),
                Quantity::Force,
                fs
            ))
            .contains("must be a motion")
        );
        let mut bad = x.clone();
        bad[7] = f64::NAN;
        assert!(err(mk(force.clone(), Quantity::Force, bad, d, fs)).contains("response[7]"));
        assert!(err(mk(vec![0.0; n], Quantity::Force, x.clone(), d, fs)).contains("flat"));
        assert!(err(mk(force, Quantity::Force, x, d, 0.0)).contains("sample_rate_hz"));
    }
}
