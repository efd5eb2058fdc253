//! The structural model: the underlying linear structure plus elements.
//!
//! Paper eq. (1): `m x'' + c x' + k x = F − F_nl`. The linear part is a
//! [`ModalModel`] (one or more modes at the joint point); `F_nl` is the sum of
//! the forces of the [`Element`]s attached there: the joint (Jenkins or the
//! eq. (10) Masing element) and any effects (cubic stiffness, ...).
//!
//! [`ElementSpec`] is an element's kind and parameters as data (what TOML files,
//! fits and reports handle); [`AnyElement`] is the element built from it, with
//! state, dispatched without virtual calls in the simulator's loop.

pub mod element;
pub mod jenkins;
pub mod masing;
pub mod modal;
pub mod smooth;

pub use element::{Element, ElementForce, ElementKind, ElementSet, ImplicitStep, NoElement};
pub use jenkins::Jenkins;
pub use masing::{Backbone, Masing, PiecewiseLinearBackbone, PowerBackbone};
pub use modal::{ModalModel, Mode};
pub use smooth::{BilinearStiffness, Clearance, CubicStiffness, QuadraticDamping, ViscousDamping};

use crate::error::{Error, Result, require_finite, require_non_negative, require_positive};
use serde::{Deserialize, Serialize};

/// An element's kind and parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ElementSpec {
    /// Spring `kd` (N/m) in series with a Coulomb slider `fd` (N).
    Jenkins {
        /// Stick stiffness, N/m.
        kd: f64,
        /// Slip force, N.
        fd: f64,
    },
    /// Eq. (10) backbone with Masing rules.
    Masing {
        /// Stick stiffness, N/m.
        kd: f64,
        /// Slip force, N.
        fd: f64,
        /// Curvature exponent.
        n: f64,
    },
    /// `k3 x³`.
    CubicStiffness {
        /// N/m³, either sign.
        k3: f64,
    },
    /// `c2 |v| v`.
    QuadraticDamping {
        /// N s²/m².
        c2: f64,
    },
    /// `kb x` for `x > 0`.
    BilinearStiffness {
        /// N/m.
        kb: f64,
    },
    /// A spring `k` beyond a symmetric gap `±gap`.
    Clearance {
        /// N/m.
        k: f64,
        /// m.
        gap: f64,
    },
    /// An extra viscous damper `cj v`.
    ViscousDamping {
        /// N s/m.
        cj: f64,
    },
}

impl ElementSpec {
    /// The kind.
    pub fn kind(&self) -> ElementKind {
        match self {
            ElementSpec::Jenkins { .. } => ElementKind::Jenkins,
            ElementSpec::Masing { .. } => ElementKind::Masing,
            ElementSpec::CubicStiffness { .. } => ElementKind::CubicStiffness,
            ElementSpec::QuadraticDamping { .. } => ElementKind::QuadraticDamping,
            ElementSpec::BilinearStiffness { .. } => ElementKind::BilinearStiffness,
            ElementSpec::Clearance { .. } => ElementKind::Clearance,
            ElementSpec::ViscousDamping { .. } => ElementKind::ViscousDamping,
        }
    }

    /// Parameter names and values, in a fixed order.
    pub fn parameters(&self) -> Vec<(&'static str, f64)> {
        match *self {
            ElementSpec::Jenkins { kd, fd } => vec![("kd", kd), ("fd", fd)],
            ElementSpec::Masing { kd, fd, n } => vec![("kd", kd), ("fd", fd), ("n", n)],
            ElementSpec::CubicStiffness { k3 } => vec![("k3", k3)],
            ElementSpec::QuadraticDamping { c2 } => vec![("c2", c2)],
            ElementSpec::BilinearStiffness { kb } => vec![("kb", kb)],
            ElementSpec::Clearance { k, gap } => vec![("k", k), ("gap", gap)],
            ElementSpec::ViscousDamping { cj } => vec![("cj", cj)],
        }
    }

    /// The same kind with parameters replaced, in the order of
    /// [`ElementSpec::parameters`].
    ///
    /// # Panics
    /// If `values` has the wrong length (a programming error).
    pub fn with_parameters(&self, values: &[f64]) -> ElementSpec {
        let n = self.parameters().len();
        assert_eq!(
            values.len(),
            n,
            "{} takes {n} parameters",
            self.kind().name()
        );
        match self {
            ElementSpec::Jenkins { .. } => ElementSpec::Jenkins {
                kd: values[0],
                fd: values[1],
            },
            ElementSpec::Masing { .. } => ElementSpec::Masing {
                kd: values[0],
                fd: values[1],
                n: values[2],
            },
            ElementSpec::CubicStiffness { .. } => ElementSpec::CubicStiffness { k3: values[0] },
            ElementSpec::QuadraticDamping { .. } => ElementSpec::QuadraticDamping { c2: values[0] },
            ElementSpec::BilinearStiffness { .. } => {
                ElementSpec::BilinearStiffness { kb: values[0] }
            }
            ElementSpec::Clearance { .. } => ElementSpec::Clearance {
                k: values[0],
                gap: values[1],
            },
            ElementSpec::ViscousDamping { .. } => ElementSpec::ViscousDamping { cj: values[0] },
        }
    }

    /// Checks the parameters; `at` prefixes the field names in messages
    /// (e.g. `joint` or `effects[1]`).
    pub fn validate(&self, at: &str) -> Result<()> {
        let f = |p: &str| format!("{at}.{p}");
        match *self {
            ElementSpec::Jenkins { kd, fd } => {
                require_positive(&f("kd"), kd)?;
                require_positive(&f("fd"), fd)
            }
            ElementSpec::Masing { kd, fd, n } => {
                require_positive(&f("kd"), kd)?;
                require_positive(&f("fd"), fd)?;
                masing::validate_curvature(&f("n"), n)
            }
            ElementSpec::CubicStiffness { k3 } => require_finite(&f("k3"), k3),
            ElementSpec::QuadraticDamping { c2 } => require_non_negative(&f("c2"), c2),
            ElementSpec::BilinearStiffness { kb } => require_finite(&f("kb"), kb),
            ElementSpec::Clearance { k, gap } => {
                require_non_negative(&f("k"), k)?;
                require_non_negative(&f("gap"), gap)
            }
            ElementSpec::ViscousDamping { cj } => require_non_negative(&f("cj"), cj),
        }
    }

    /// Builds a virgin element.
    pub fn build(&self) -> Result<AnyElement> {
        self.validate(self.kind().name())?;
        Ok(match *self {
            ElementSpec::Jenkins { kd, fd } => AnyElement::Jenkins(Jenkins::new(kd, fd)?),
            ElementSpec::Masing { kd, fd, n } => AnyElement::Masing(Masing::new(kd, fd, n)?),
            ElementSpec::CubicStiffness { k3 } => AnyElement::CubicStiffness(CubicStiffness { k3 }),
            ElementSpec::QuadraticDamping { c2 } => {
                AnyElement::QuadraticDamping(QuadraticDamping { c2 })
            }
            ElementSpec::BilinearStiffness { kb } => {
                AnyElement::BilinearStiffness(BilinearStiffness { kb })
            }
            ElementSpec::Clearance { k, gap } => AnyElement::Clearance(Clearance { k, gap }),
            ElementSpec::ViscousDamping { cj } => AnyElement::ViscousDamping(ViscousDamping { cj }),
        })
    }

    /// The element's steady force–displacement loop under `x = a cos θ`:
    /// the second of two periods of `samples` points from the virgin state
    /// (for plots of hysteresis loops, paper Fig. 3.2).
    pub fn steady_loop(&self, amplitude: f64, samples: usize) -> Result<(Vec<f64>, Vec<f64>)> {
        let mut e = self.build()?;
        let n = samples.max(8);
        let (mut xs, mut fs) = (Vec::with_capacity(n + 1), Vec::with_capacity(n + 1));
        for i in 0..=2 * n {
            let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            let x = amplitude * th.cos();
            let v = -amplitude * th.sin();
            let f = e.commit(x, v).force;
            if i >= n {
                xs.push(x);
                fs.push(f);
            }
        }
        Ok((xs, fs))
    }

    /// The stick stiffness a hysteresis element adds at small amplitude
    /// (0 for the others).
    pub fn stick_stiffness(&self) -> f64 {
        match *self {
            ElementSpec::Jenkins { kd, .. } | ElementSpec::Masing { kd, .. } => kd,
            _ => 0.0,
        }
    }
}

/// Any built-in element, with its state.
#[derive(Clone, Debug)]
pub enum AnyElement {
    /// See [`Jenkins`].
    Jenkins(Jenkins),
    /// See [`Masing`].
    Masing(Masing),
    /// See [`CubicStiffness`].
    CubicStiffness(CubicStiffness),
    /// See [`QuadraticDamping`].
    QuadraticDamping(QuadraticDamping),
    /// See [`BilinearStiffness`].
    BilinearStiffness(BilinearStiffness),
    /// See [`Clearance`].
    Clearance(Clearance),
    /// See [`ViscousDamping`].
    ViscousDamping(ViscousDamping),
}

macro_rules! dispatch {
    ($self:expr, $e:ident => $body:expr) => {
        match $self {
            AnyElement::Jenkins($e) => $body,
            AnyElement::Masing($e) => $body,
            AnyElement::CubicStiffness($e) => $body,
            AnyElement::QuadraticDamping($e) => $body,
            AnyElement::BilinearStiffness($e) => $body,
            AnyElement::Clearance($e) => $body,
            AnyElement::ViscousDamping($e) => $body,
        }
    };
}

impl Element for AnyElement {
    #[inline]
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        dispatch!(self, e => e.trial(x, v))
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        dispatch!(self, e => e.commit(x, v))
    }
    fn reset(&mut self) {
        dispatch!(self, e => e.reset())
    }
    fn has_memory(&self) -> bool {
        dispatch!(self, e => e.has_memory())
    }
    fn uses_velocity(&self) -> bool {
        dispatch!(self, e => e.uses_velocity())
    }
    #[inline]
    fn solve_implicit(&self, step: &ImplicitStep) -> Option<f64> {
        dispatch!(self, e => e.solve_implicit(step))
    }
    #[inline]
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        dispatch!(self, e => e.commit_sensitivity(x, v, dx, dv, df))
    }
}

/// A structure: the underlying linear modes and the elements at the joint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Model {
    /// The underlying linear structure.
    pub linear: ModalModel,
    /// The elements; their forces add.
    pub elements: Vec<ElementSpec>,
}

impl Model {
    /// A model; checks every part.
    pub fn new(linear: ModalModel, elements: Vec<ElementSpec>) -> Result<Model> {
        let m = Model { linear, elements };
        m.validate()?;
        Ok(m)
    }

    /// Checks every part.
    pub fn validate(&self) -> Result<()> {
        self.linear.validate()?;
        for (i, e) in self.elements.iter().enumerate() {
            e.validate(&format!("elements[{i}]"))?;
        }
        Ok(())
    }

    /// The elements, built and virgin.
    pub fn element_set(&self) -> Result<ElementSet<AnyElement>> {
        Ok(ElementSet::new(
            self.elements
                .iter()
                .map(ElementSpec::build)
                .collect::<Result<_>>()?,
        ))
    }

    /// Total stick stiffness the hysteresis elements add at small amplitude.
    pub fn stick_stiffness(&self) -> f64 {
        self.elements.iter().map(ElementSpec::stick_stiffness).sum()
    }

    /// The highest frequency the linearised structure can ring at, Hz: the
    /// highest mode, or the SDOF's stick natural frequency `√((k + kd)/m)/2π`
    /// when a hysteresis element stiffens it. Sample rates are counted against
    /// it, not against the drive: the filter must resolve the stick mode.
    pub fn highest_linearised_frequency_hz(&self) -> f64 {
        let kd = self.stick_stiffness();
        self.linear
            .modes
            .iter()
            .map(|m| {
                let w2 = m.omega().powi(2) + kd * m.residue.abs();
                w2.sqrt() / (2.0 * std::f64::consts::PI)
            })
            .fold(0.0, f64::max)
    }

    /// Whether any element has memory.
    pub fn has_memory(&self) -> bool {
        self.elements
            .iter()
            .any(|e| matches!(e.kind(), ElementKind::Jenkins | ElementKind::Masing))
    }

    /// Whether any element breaks the half-wave symmetry (makes even
    /// harmonics and DC under symmetric forcing).
    pub fn is_asymmetric(&self) -> bool {
        self.elements
            .iter()
            .any(|e| matches!(e.kind(), ElementKind::BilinearStiffness))
    }

    /// Error unless `name` is a parameter of element `index`.
    pub fn parameter_index(&self, index: usize, name: &str) -> Result<usize> {
        let e = self
            .elements
            .get(index)
            .ok_or_else(|| Error::model(format!("elements[{index}]"), "no such element"))?;
        e.parameters()
            .iter()
            .position(|(p, _)| *p == name)
            .ok_or_else(|| {
                Error::model(
                    format!("elements[{index}].{name}"),
                    format!("{} has no such parameter", e.kind().name()),
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_from_toml_and_reject_unknown_keys() {
        #[derive(Deserialize)]
        struct W {
            joint: ElementSpec,
        }
        let w: W =
            toml::from_str("[joint]\nkind = \"jenkins\"\nkd = 2.4e7\nfd = 246.048\n").unwrap();
        assert_eq!(
            w.joint,
            ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048
            }
        );
        let e = toml::from_str::<W>("[joint]\nkind = \"jenkins\"\nkd = 2.4e7\nfd = 1.0\nkx = 3\n")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("kx"), "{e}");
        let e = toml::from_str::<W>("[joint]\nkind = \"bouncy\"\n")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("bouncy"), "{e}");
    }

    #[test]
    fn parameters_round_trip() {
        let s = ElementSpec::Masing {
            kd: 1.0,
            fd: 2.0,
            n: 3.0,
        };
        let v: Vec<f64> = s.parameters().iter().map(|p| p.1).collect();
        assert_eq!(s.with_parameters(&v), s);
        assert!(
            ElementSpec::Masing {
                kd: 1.0,
                fd: -2.0,
                n: 3.0
            }
            .build()
            .is_err()
        );
    }

    #[test]
    fn stick_frequency_of_the_paper_system() {
        let m = Model::new(
            ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            vec![ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048,
            }],
        )
        .unwrap();
        let f = m.highest_linearised_frequency_hz();
        assert!((f - (3.4e7f64 / 10.0).sqrt() / (2.0 * std::f64::consts::PI)).abs() < 1e-9);
    }
}
