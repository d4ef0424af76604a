//! How the kinds of a boundary's rows and special points are named in its files
//! (`boundary.csv`, `points.csv`), and read back from them by a resumed study.

use serde::{Deserialize, Deserializer, Serializer};
use strum::IntoEnumIterator;

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

/// The kind named in a file (read back by a resumed study): the string parsed by `parse`, else
/// an error that names the string and every name `kinds` has.
fn of_name<'de, D: Deserializer<'de>, T>(
    d: D,
    parse: impl Fn(&str) -> Option<T>,
    kinds: impl Iterator<Item = &'static str>,
) -> std::result::Result<T, D::Error> {
    let text = String::deserialize(d)?;
    parse(&text).ok_or_else(|| {
        let names: Vec<&str> = kinds.collect();
        serde::de::Error::custom(format!("`{text}` is none of {}", names.join(", ")))
    })
}

pub(super) fn event_of_name<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<EventKind, D::Error> {
    of_name(
        d,
        |text| text.parse().ok(),
        EventKind::iter().map(EventKind::name),
    )
}

pub(super) fn special_of_name<'de, D: Deserializer<'de>>(
    d: D,
) -> std::result::Result<BoundaryEvent, D::Error> {
    let window = BoundaryEvent::Window;
    of_name(
        d,
        |text| match text.parse() {
            Ok(kind) => Some(BoundaryEvent::Curve(kind)),
            Err(_) => (text == window.name()).then_some(window),
        },
        SpecialKind::iter()
            .map(SpecialKind::name)
            .chain([window.name()]),
    )
}

#[cfg(test)]
mod tests {
    use serde::{Deserialize, Serialize};

    use super::*;

    /// One row with both kinds, as `boundary.csv` and `points.csv` hold them.
    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Row {
        #[serde(serialize_with = "event_name", deserialize_with = "event_of_name")]
        event: EventKind,
        #[serde(serialize_with = "special_name", deserialize_with = "special_of_name")]
        special: BoundaryEvent,
    }

    /// Every kind of event and special point written to CSV is read back as itself, and the
    /// names written are the documented ones (docs/commands.md); a name of neither is refused
    /// with the names allowed.
    #[test]
    fn every_kind_written_to_a_file_is_read_back_as_itself() {
        let events: Vec<EventKind> = EventKind::iter().collect();
        let specials: Vec<BoundaryEvent> = SpecialKind::iter()
            .map(BoundaryEvent::Curve)
            .chain([BoundaryEvent::Window])
            .collect();
        let mut writer = csv::Writer::from_writer(vec![]);
        for (i, &special) in specials.iter().enumerate() {
            let event = events[i % events.len()];
            writer.serialize(Row { event, special }).unwrap();
        }
        let text = String::from_utf8(writer.into_inner().unwrap()).unwrap();
        assert_eq!(
            text,
            "event,special\nfold,double_hopf\nbranch_point,zero_hopf\nhopf,turning\n\
             mode_exchange,bogdanov_takens\nfold,generalized_hopf\nbranch_point,window\n"
        );
        let rows: Vec<Row> = csv::Reader::from_reader(text.as_bytes())
            .deserialize()
            .collect::<std::result::Result<_, _>>()
            .unwrap();
        for (row, &special) in rows.iter().zip(&specials) {
            assert_eq!(row.special, special);
        }
        let read: Vec<EventKind> = rows.iter().map(|r| r.event).take(events.len()).collect();
        assert_eq!(read, events);
        let bad = "event,special\nhopf,cusp\n";
        let error = csv::Reader::from_reader(bad.as_bytes())
            .deserialize::<Row>()
            .next()
            .unwrap()
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("`cusp` is none of double_hopf, zero_hopf, turning, bogdanov_takens, generalized_hopf, window"),
            "{error}"
        );
    }
}
