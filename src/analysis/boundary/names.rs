//! How the kinds of a boundary's rows and special points are named in its files
//! (`boundary.csv`, `points.csv`), and read back from them by a resumed study.

use serde::{Deserialize, Deserializer, Serializer};

use super::BoundaryEvent;
use crate::engine::curve::SpecialKind;
use crate::engine::events::EventKind;

pub(super) fn event_name<S: Serializer>(
    kind: &EventKind,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(kind.name())
}

pub(super) fn special_name<S: Serializer>(
    kind: &BoundaryEvent,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_str(kind.name())
}

/// The one of `kinds` named `name` in a file (read back by a resumed study).
fn of_name<'de, D: Deserializer<'de>, T: Copy>(
    d: D,
    kinds: &[T],
    name: fn(T) -> &'static str,
) -> std::result::Result<T, D::Error> {
    let text = String::deserialize(d)?;
    kinds
        .iter()
        .copied()
        .find(|&k| name(k) == text)
        .ok_or_else(|| {
            let names: Vec<&str> = kinds.iter().map(|&k| name(k)).collect();
            serde::de::Error::custom(format!("`{text}` is none of {}", names.join(", ")))
        })
}

pub(super) fn event_of_name<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<EventKind, D::Error> {
    use EventKind::{BranchPoint, Fold, Hopf, ModeExchange};
    of_name(d, &[Fold, BranchPoint, Hopf, ModeExchange], EventKind::name)
}

pub(super) fn special_of_name<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<BoundaryEvent, D::Error> {
    let kinds = SpecialKind::ALL.map(BoundaryEvent::Curve);
    of_name(
        d,
        &[kinds.as_slice(), &[BoundaryEvent::Window]].concat(),
        BoundaryEvent::name,
    )
}
