//! Identification: fit the element parameters so that the harmonic-balance
//! model's nonlinear FRFs match the measured ones (paper Figures 2.2 and 3.3,
//! eq. 9); or, from such a fit, the recording itself replayed in the time
//! domain ([`time`]).

pub mod anchor;
pub mod coil;
pub mod identify;
pub mod linear;

pub use anchor::LinearAnchor;
pub use linear::{FrfSample, SdofEstimate, fit_sdof};
pub mod optimise;
pub mod params;
pub mod points;
pub mod predict;
pub mod problem;
pub mod time;

pub use identify::{Estimate, FitOptions, FitResult, LinearRefinement, LinearStart, identify};
pub use optimise::{FitStatus, Optimiser, OptimiserRun};
pub use params::{N_MAX, Parameter, ParameterSet, Target, Transform};
pub use predict::HbPredictor;
pub use problem::{
    FitData, FitProblem, FrfPredictor, MeasuredPoint, MeasuredSeries, Prediction, SubharmonicPoint,
    Weighting, usable_point,
};
pub use time::{TimeFitOptions, TimeFitResult, TimeRecord, identify_time};
