//! The units a model's parameters are stated in: a law's from its
//! description, the linear part's by name; in volts where the model's
//! forces are measured against a voltage (one mapping, [`in_drive_units`]).

use super::{Domain, ElementKind, ElementSpec, Model};
use crate::harmonics::Quantity;

/// The unit and domain of parameter `name` of `model`: an element's from
/// its law's description, the linear part's by name.
pub fn describe(name: &str, model: &Model) -> (&'static str, Option<Domain>) {
    // an element's parameter: the name its fit gives it (the joint's plain,
    // an effect's or a hysteretic mode's joint's after a prefix)
    for (at, e) in model.placed_all() {
        let prefix = model.parameter_prefix(at);
        let leaf = if prefix.is_empty() {
            Some(name)
        } else {
            name.strip_prefix(prefix.as_str())
                .and_then(|r| r.strip_prefix('.'))
        };
        if let Some(info) =
            leaf.and_then(|l| e.description().parameters.iter().find(|q| q.name == l))
        {
            return (info.unit, Some(info.domain));
        }
    }
    linear_part(name.rsplit_once('.').map_or(name, |(_, l)| l))
}

/// The unit and domain of the linear part's parameter `leaf` (in newtons).
fn linear_part(leaf: &str) -> (&'static str, Option<Domain>) {
    match leaf {
        "mass" | "modal_mass" => ("kg", Some(Domain::Positive)),
        "damping" => ("N s/m", Some(Domain::NonNegative)),
        "stiffness" => ("N/m", Some(Domain::Positive)),
        "frequency_hz" => ("Hz", Some(Domain::Positive)),
        "damping_ratio" => ("", Some(Domain::Range { min: 0.0, max: 1.0 })),
        "residue" => ("1/kg", None),
        "flexibility" => ("m/N", None),
        _ => ("", None),
    }
}

/// The unit parameter `name` of `model` is stated in when `model`'s forces
/// are measured against a reference of quantity `drive` (see
/// [`force_drive`]): [`describe`]'s, in volts on a voltage reference.
pub fn parameter_unit(name: &str, model: &Model, drive: Quantity) -> &'static str {
    in_drive_units(describe(name, model).0, drive)
}

/// [`parameter_unit`] of parameter `name` of a law `law` not (or not yet) in
/// a model (a diagnosis's candidate; none: a mode's), in volts on a voltage
/// reference.
pub fn law_parameter_unit(law: Option<ElementKind>, name: &str, drive: Quantity) -> &'static str {
    let own = law.and_then(|k| k.description().parameters.iter().find(|q| q.name == name));
    in_drive_units(own.map_or_else(|| linear_part(name).0, |q| q.unit), drive)
}

/// ` unit` after a value, nothing for a dimensionless parameter.
pub fn unit_suffix(unit: &str) -> String {
    if unit.is_empty() || unit == "1" {
        String::new()
    } else {
        format!(" {unit}")
    }
}

/// `unit` (a model parameter's, in newtons) for a model driven by a
/// reference of quantity `drive`: with a voltage reference (an amplifier's
/// drive, the structure's force not measured) the model's "forces" are in
/// volts, so a slip force is in V, a stiffness in V/m and a mass in V s²/m.
pub fn in_drive_units(unit: &'static str, drive: Quantity) -> &'static str {
    if drive != Quantity::Voltage {
        return unit;
    }
    match unit {
        "N" => "V",
        "N/m" => "V/m",
        "N s/m" => "V s/m",
        "N/m³" => "V/m³",
        "N s²/m²" => "V s²/m²",
        "N^(1-nu)/m" => "V^(1-nu)/m",
        "kg" => "V s²/m",
        "1/kg" => "m/(V s²)",
        "m/N" => "m/V",
        "N/V" => "V/V",
        other => other,
    }
}

/// What `model`'s forces are measured against with a reference of quantity
/// `reference`: the reference's own unit, unless a shaker declared by its
/// coil (a gain other than 1, `Bl/R`) turns the voltage into newtons.
pub fn force_drive(model: &Model, reference: Quantity) -> Quantity {
    match model.laws().find_map(ElementSpec::drive_load) {
        Some(load) if load.gain != 1.0 => Quantity::Force,
        _ => reference,
    }
}
