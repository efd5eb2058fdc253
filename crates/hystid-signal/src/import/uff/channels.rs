//! Time records of a UFF file made recording channels: their quantities and
//! units, names, sample rates, and the load of an import.

use super::types::{Abscissa, Dataset, Function, Ordinate, Precision, UffFile, function_type_name};
use crate::harmonics::Quantity;
use crate::import::{ChannelSpec, Column, ImportSpec, Loaded, SampleRateSource};
use crate::{Error, Result};
use std::path::Path;

/// Why a dataset 58 does not become a recording channel.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NotAChannel {
    /// Not a time response.
    #[error("function type {0} ({name}), not a time response (1)", name = function_type_name(*.0))]
    NotTimeResponse(i64),
    /// A complex ordinate.
    #[error("a complex ordinate (data type 5 or 6): a time record must be real")]
    Complex,
    /// Record 9 names no quantity hystid knows.
    #[error(
        "ordinate data type {data_type} with units label `{units}`: not force (13, 9), \
         displacement (8), velocity (11), acceleration (12) or voltage (units V)"
    )]
    Quantity {
        /// Record 9 field 1.
        data_type: i64,
        /// Record 9 field 6.
        units: String,
    },
    /// A units label that is not a unit of the quantity.
    #[error("units label `{units}` is not a unit of {quantity} (known: {known})")]
    Units {
        /// The quantity record 9 gives.
        quantity: Quantity,
        /// The label.
        units: String,
        /// The labels understood for that quantity.
        known: String,
    },
}

/// A time record as a recording channel: its quantity and the factor from
/// its units to SI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeChannel {
    /// The quantity.
    pub quantity: Quantity,
    /// SI value = value in the file × scale.
    pub scale: f64,
    /// The units label was `NONE` or blank, so SI was assumed.
    pub si_assumed: bool,
}

/// Units labels understood, per quantity, with their factor to SI. Labels
/// are compared after [`unit_key`].
const UNITS: [(Quantity, &[(&str, f64)]); 5] = [
    (
        Quantity::Force,
        &[
            ("N", 1.0),
            ("kN", 1e3),
            ("mN", 1e-3),
            ("lbf", 4.448_221_615_260_5),
            ("lb", 4.448_221_615_260_5),
            ("kgf", 9.806_65),
        ],
    ),
    (
        Quantity::Acceleration,
        &[
            ("m/s2", 1.0),
            ("g", 9.806_65),
            ("gn", 9.806_65),
            ("mm/s2", 1e-3),
            ("in/s2", 0.0254),
            ("ft/s2", 0.3048),
        ],
    ),
    (
        Quantity::Velocity,
        &[
            ("m/s", 1.0),
            ("mm/s", 1e-3),
            ("um/s", 1e-6),
            ("in/s", 0.0254),
            ("ft/s", 0.3048),
        ],
    ),
    (
        Quantity::Displacement,
        &[
            ("m", 1.0),
            ("mm", 1e-3),
            ("um", 1e-6),
            ("nm", 1e-9),
            ("in", 0.0254),
            ("mil", 2.54e-5),
            ("ft", 0.3048),
        ],
    ),
    (Quantity::Voltage, &[("V", 1.0), ("mV", 1e-3)]),
];

/// A units label in the spelling [`UNITS`] uses: brackets, blanks dropped,
/// `²`, `^2`, `**2`, `/s/s` as `2` and `/s2`, `µ` as `u`.
fn unit_key(label: &str) -> String {
    let mut s: String = label
        .chars()
        .filter(|c| !c.is_whitespace() && !matches!(c, '[' | ']' | '(' | ')'))
        .map(|c| match c {
            'µ' | 'μ' => 'u',
            '²' => '2',
            c => c,
        })
        .collect();
    for (from, to) in [("**2", "2"), ("^2", "2"), ("/s/s", "/s2")] {
        s = s.replace(from, to);
    }
    s
}

fn is_none(label: &str) -> bool {
    label.is_empty() || label.eq_ignore_ascii_case("NONE")
}

/// The quantity and scale of a time record, from record 9's specific data
/// type (13 excitation force, 9 reaction force, 8 displacement, 11
/// velocity, 12 acceleration; for 0 unknown and 1 general the units label
/// alone) and its units label.
pub fn time_channel(f: &Function) -> std::result::Result<TimeChannel, NotAChannel> {
    if f.function_type != 1 {
        return Err(NotAChannel::NotTimeResponse(f.function_type));
    }
    if matches!(f.ordinate, Ordinate::Complex(_)) {
        return Err(NotAChannel::Complex);
    }
    let axis = &f.ordinate_axis;
    let key = unit_key(&axis.units);
    let by_units = || {
        let found: Vec<Quantity> = UNITS
            .iter()
            .filter(|(_, table)| table.iter().any(|(u, _)| *u == key))
            .map(|(q, _)| *q)
            .collect();
        (found.len() == 1).then(|| found[0])
    };
    let quantity = match axis.data_type {
        13 | 9 => Quantity::Force,
        8 => Quantity::Displacement,
        11 => Quantity::Velocity,
        12 => Quantity::Acceleration,
        0 | 1 => by_units().ok_or_else(|| NotAChannel::Quantity {
            data_type: axis.data_type,
            units: axis.units.clone(),
        })?,
        t => {
            return Err(NotAChannel::Quantity {
                data_type: t,
                units: axis.units.clone(),
            });
        }
    };
    if is_none(&axis.units) {
        return Ok(TimeChannel {
            quantity,
            scale: 1.0,
            si_assumed: true,
        });
    }
    let table = UNITS
        .iter()
        .find(|(q, _)| *q == quantity)
        .map_or(&[][..], |(_, t)| *t);
    match table.iter().find(|(u, _)| *u == key) {
        Some(&(_, scale)) => Ok(TimeChannel {
            quantity,
            scale,
            si_assumed: false,
        }),
        None => Err(NotAChannel::Units {
            quantity,
            units: axis.units.clone(),
            known: table.iter().map(|(u, _)| *u).collect::<Vec<_>>().join(", "),
        }),
    }
}

/// The channel name a time record gets by default: `force_1+Z`,
/// `acceleration_12-X`; for a scalar DOF at node 0 its entity name, else
/// `QUANTITY_K` (K the dataset's position).
pub fn default_name(d: &Dataset, f: &Function, q: Quantity) -> String {
    if f.response.node != 0 || f.response.direction != 0 {
        format!("{}_{}", q.name(), f.response.label())
    } else if !is_none(&f.response.entity) {
        f.response.entity.clone()
    } else {
        format!("{}_{}", q.name(), d.index)
    }
}

/// The channels of a file, as an import spec would name them: every real
/// time record whose quantity record 9 gives, excitation forces first (the
/// recording's reference is its first force), then the rest in file order;
/// each with its unit's scale. Returns them with a note for each dataset
/// left out.
pub fn channels(path: &Path, file: &UffFile) -> Result<(Vec<ChannelSpec>, Vec<String>)> {
    let mut notes = Vec::new();
    let mut found: Vec<(bool, ChannelSpec)> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for d in &file.datasets {
        let Some(f) = &d.function else {
            notes.push(format!(
                "{} skipped: hystid reads dataset 58 only",
                d.describe()
            ));
            continue;
        };
        match time_channel(f) {
            Ok(c) => {
                let mut name = default_name(d, f, c.quantity);
                if names.contains(&name) {
                    name = format!("{name}_{}", d.index);
                }
                names.push(name.clone());
                if c.si_assumed {
                    notes.push(format!(
                        "{}: no units label, SI ({}) assumed",
                        d.describe(),
                        c.quantity.si_unit()
                    ));
                }
                let spec = ChannelSpec::new(Column::Index(d.index), c.quantity)
                    .name(name)
                    .scale(c.scale);
                found.push((f.ordinate_axis.data_type == 13, spec));
            }
            Err(e) => notes.push(format!("{} skipped: {e}", d.describe())),
        }
    }
    if found.is_empty() {
        return Err(Error::format(
            path,
            "UFF",
            format!(
                "no time record (dataset 58, function type 1) of force, displacement, velocity, \
                 acceleration or voltage: {}; datasets: {}",
                notes.join("; "),
                file.listing()
            ),
        ));
    }
    // a stable sort: excitation forces first
    found.sort_by_key(|(excitation, _)| !excitation);
    Ok((found.into_iter().map(|(_, c)| c).collect(), notes))
}

/// The dataset a channel spec names: `#K` (its position in the file), or a
/// name: the default channel name, the response entity name, `NODE±DIR` or
/// ID line 1.
fn resolve<'a>(
    path: &Path,
    file: &'a UffFile,
    c: &ChannelSpec,
    k: usize,
) -> Result<(&'a Dataset, &'a Function)> {
    let field = format!("channels[{k}].source");
    if c.row.is_some() {
        return Err(Error::plan(
            format!("channels[{k}].row"),
            "a UFF dataset holds one signal: no row",
        ));
    }
    match &c.source {
        Column::Index(i) => {
            let d = file.datasets.get(i.wrapping_sub(1)).ok_or_else(|| {
                Error::plan(
                    &field,
                    format!(
                        "dataset #{i}: {} holds {} datasets ({})",
                        path.display(),
                        file.datasets.len(),
                        file.listing()
                    ),
                )
            })?;
            match &d.function {
                Some(f) => Ok((d, f)),
                None => Err(Error::plan(
                    field,
                    format!(
                        "{} of {} is not a dataset 58 ({})",
                        d.describe(),
                        path.display(),
                        file.listing()
                    ),
                )),
            }
        }
        Column::Name(name) => {
            let hits: Vec<(&Dataset, &Function)> = file
                .functions()
                .filter(|(d, f)| {
                    let q = time_channel(f).map(|t| t.quantity);
                    q.is_ok_and(|q| default_name(d, f, q) == *name)
                        || f.response.entity == *name
                        || f.response.label() == *name
                        || f.id_lines[0] == *name
                })
                .collect();
            match hits.as_slice() {
                [one] => Ok(*one),
                [] => Err(Error::plan(
                    field,
                    format!(
                        "no dataset 58 of {} is named `{name}` (by channel name, response \
                         entity, NODE+DIR or ID line 1); use #K for the K-th dataset: {}",
                        path.display(),
                        file.listing()
                    ),
                )),
                many => Err(Error::plan(
                    field,
                    format!(
                        "`{name}` names datasets {} of {}: use #K",
                        many.iter()
                            .map(|(d, _)| format!("#{}", d.index))
                            .collect::<Vec<_>>()
                            .join(", "),
                        path.display()
                    ),
                )),
            }
        }
    }
}

/// The sample rate an even abscissa gives: `1/increment`, or the whole
/// number of Hz whose period the file's printed increment is (within half
/// its last digit: `1.52588E-05` is 65536 Hz, not 65536.1).
pub fn rate_of(increment: f64, resolution: f64) -> f64 {
    let fs = 1.0 / increment;
    let whole = fs.round();
    if whole >= 1.0 && (1.0 / whole - increment).abs() <= resolution {
        whole
    } else {
        fs
    }
}

/// The recording's channels from the datasets `spec` names (all time
/// records when it names none: see [`channels`]); the rate from the
/// abscissa. Returns the completed spec with what the reader loaded.
pub(crate) fn load(path: &Path, file: &UffFile, spec: &ImportSpec) -> Result<(ImportSpec, Loaded)> {
    let mut spec = spec.clone();
    let mut notes = Vec::new();
    if spec.channels.is_empty() {
        let (c, n) = channels(path, file)?;
        spec.channels = c;
        notes = n;
    }
    let mut chosen = Vec::with_capacity(spec.channels.len());
    for k in 0..spec.channels.len() {
        let (d, f) = resolve(path, file, &spec.channels[k], k)?;
        let c = &mut spec.channels[k];
        if c.name.is_none() && matches!(c.source, Column::Index(_)) {
            // `#3` would read `column_3`: the dataset's own name instead
            c.name = Some(default_name(d, f, c.quantity));
        }
        let c = &spec.channels[k];
        if f.function_type != 1 {
            return Err(Error::format(
                path,
                d.describe(),
                format!(
                    "channel `{}`: {}",
                    c.channel_name(),
                    NotAChannel::NotTimeResponse(f.function_type)
                ),
            ));
        }
        let Ordinate::Real(y) = &f.ordinate else {
            return Err(Error::format(
                path,
                d.describe(),
                format!("channel `{}`: {}", c.channel_name(), NotAChannel::Complex),
            ));
        };
        if y.is_empty() {
            return Err(Error::format(path, d.describe(), "holds no values"));
        }
        chosen.push((d, f, y));
    }
    let (d0, f0, _) = chosen[0];
    let period0 = |f: &Function| match &f.abscissa {
        Abscissa::Even { increment, .. } => *increment,
        Abscissa::Uneven(x) => {
            if x.len() > 1 {
                (x[x.len() - 1] - x[0]) / (x.len() - 1) as f64
            } else {
                f64::NAN
            }
        }
    };
    for &(d, f, _) in &chosen[1..] {
        let mismatch = |what: String| {
            Error::format(
                path,
                d.describe(),
                format!(
                    "{what}; a recording's channels are sampled together (choose datasets \
                     with --channel #K)"
                ),
            )
        };
        if f.ordinate.len() != f0.ordinate.len() {
            return Err(mismatch(format!(
                "{} values, but {} has {}",
                f.ordinate.len(),
                d0.describe(),
                f0.ordinate.len()
            )));
        }
        match (&f.abscissa, &f0.abscissa) {
            (
                Abscissa::Even {
                    start,
                    increment,
                    increment_resolution: r,
                },
                Abscissa::Even {
                    start: s0,
                    increment: i0,
                    increment_resolution: r0,
                },
            ) => {
                if (increment - i0).abs() > r.max(*r0) + 1e-12 * i0.abs() {
                    return Err(mismatch(format!(
                        "sample spacing {increment} s, but {} has {i0} s",
                        d0.describe()
                    )));
                }
                if (start - s0).abs() > 0.5 * i0.abs() {
                    return Err(mismatch(format!(
                        "starts at {start} s, but {} at {s0} s",
                        d0.describe()
                    )));
                }
            }
            (Abscissa::Uneven(x), Abscissa::Uneven(x0)) => {
                let tol = 0.01 * period0(f0).abs();
                if let Some(i) = (0..x.len()).find(|&i| {
                    let d = (x[i] - x0[i]).abs();
                    d.is_nan() || d > tol
                }) {
                    return Err(mismatch(format!(
                        "abscissa value {} is {} s, but {} has {} s",
                        i + 1,
                        x[i],
                        d0.describe(),
                        x0[i]
                    )));
                }
            }
            _ => {
                return Err(mismatch(format!(
                    "its abscissa is {} but that of {} is not",
                    if matches!(f.abscissa, Abscissa::Even { .. }) {
                        "even"
                    } else {
                        "uneven"
                    },
                    d0.describe()
                )));
            }
        }
    }
    let mut time = None;
    let (rate, origin, declared) = match (&spec.sample_rate, &f0.abscissa) {
        (
            SampleRateSource::Auto,
            Abscissa::Even {
                increment,
                increment_resolution,
                ..
            },
        ) => {
            if !(increment.is_finite() && *increment > 0.0) {
                return Err(Error::format(
                    path,
                    d0.describe(),
                    format!("abscissa increment {increment}: expected a sample spacing > 0 s"),
                ));
            }
            let fs = rate_of(*increment, *increment_resolution);
            let whole = if fs != 1.0 / increment {
                format!(": {fs} Hz within its printed digits")
            } else {
                String::new()
            };
            (
                fs,
                format!(
                    "abscissa increment {increment:e} s of dataset {} (record 7){whole}",
                    d0.index
                ),
                true,
            )
        }
        (SampleRateSource::Auto, Abscissa::Uneven(x)) => {
            let fs = crate::import::quality::rate_from_time(x)
                .map_err(|e| Error::format(path, d0.describe(), format!("uneven abscissa: {e}")))?;
            time = Some((format!("abscissa of dataset {}", d0.index), x.clone()));
            (
                fs,
                format!(
                    "uneven abscissa of dataset {} (least-squares spacing)",
                    d0.index
                ),
                false,
            )
        }
        (SampleRateSource::Value(v), x) => {
            if let Abscissa::Uneven(x) = x {
                time = Some((format!("abscissa of dataset {}", d0.index), x.clone()));
            }
            (*v, format!("given: {v} Hz"), true)
        }
        (other, _) => {
            return Err(Error::plan(
                "sample_rate",
                format!(
                    "{other:?}: a UFF file gives its rate in record 7; use auto or a value in Hz"
                ),
            ));
        }
    };
    let mut per_channel = serde_json::Map::new();
    let mut sources = Vec::new();
    let mut values = Vec::new();
    for (c, &(d, f, y)) in spec.channels.iter().zip(&chosen) {
        values.push(y.clone());
        let layout = f.binary.map(|b| {
            format!(
                "58b {}-endian {}",
                if b.big_endian { "big" } else { "little" },
                match f.precision {
                    Precision::Single => "single",
                    Precision::Double => "double",
                }
            )
        });
        sources.push(format!("dataset {} ({})", d.index, f.response.label()));
        per_channel.insert(
            c.channel_name(),
            serde_json::json!({
                "dataset": d.index,
                "line": d.line,
                "id_lines": f.id_lines,
                "function_id": f.function_id,
                "version": f.version,
                "response": {"entity": f.response.entity, "node": f.response.node,
                             "direction": f.response.direction, "label": f.response.label()},
                "reference": {"entity": f.reference.entity, "node": f.reference.node,
                              "direction": f.reference.direction},
                "ordinate_data_type": f.ordinate_axis.data_type,
                "ordinate_label": f.ordinate_axis.label,
                "units_label": f.ordinate_axis.units,
                "scale": c.scale,
                "storage": layout.unwrap_or_else(|| format!("58 ASCII {}",
                    match f.precision { Precision::Single => "single", Precision::Double => "double" })),
            }),
        );
    }
    let mut meta = serde_json::Map::new();
    meta.insert("format".into(), "UFF dataset 58".into());
    meta.insert("datasets".into(), per_channel.into());
    if !notes.is_empty() {
        meta.insert("skipped".into(), notes.clone().into());
    }
    Ok((
        spec,
        Loaded {
            values,
            sample_rate_hz: rate,
            rate_origin: origin,
            rate_declared: declared,
            time,
            metadata: meta,
            source_texts: sources,
            notes,
        },
    ))
}
