//! Reading the SVG figures of `tests/plot.rs`: their texts, polylines and colours as
//! `plotters` 0.3.7 writes them (see that file's docs), and the series the tests draw.
#![allow(dead_code)]

use std::path::PathBuf;

use helixbif::plot::{DASH_PX, Series, Style};
use roxmltree::{Document, Node};

/// Okabe–Ito colours of the first series, as the SVG writes them.
pub const BLUE: &str = "#0072B2";
pub const VERMILLION: &str = "#D55E00";
pub const GREEN: &str = "#009E73";
/// Colour of the "unstable (dashed)" legend sample.
pub const NEUTRAL: &str = "#555555";

pub fn out(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("plot-{name}.svg"))
}

pub fn read(name: &str) -> String {
    std::fs::read_to_string(out(name)).expect("figure was written")
}

pub fn parse(svg: &str) -> Document<'_> {
    Document::parse(svg).expect("the SVG is well-formed XML")
}

pub fn elements<'a, 'i>(doc: &'a Document<'i>, tag: &str) -> Vec<Node<'a, 'i>> {
    doc.descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == tag)
        .collect()
}

/// The content of every `<text>` element, trimmed.
pub fn texts(doc: &Document) -> Vec<String> {
    elements(doc, "text")
        .iter()
        .map(|n| n.text().unwrap_or("").trim().to_owned())
        .collect()
}

pub fn count_text(doc: &Document, wanted: &str) -> usize {
    texts(doc).iter().filter(|t| *t == wanted).count()
}

pub fn attr(n: &Node, name: &str) -> f64 {
    n.attribute(name)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("<{}> has a numeric {name}", n.tag_name().name()))
}

pub type Line = Vec<(f64, f64)>;

/// The vertices of every `<polyline>` stroked in `color`.
pub fn polylines(doc: &Document, color: &str) -> Vec<Line> {
    elements(doc, "polyline")
        .iter()
        .filter(|n| n.attribute("stroke") == Some(color))
        .map(|n| {
            n.attribute("points")
                .unwrap_or("")
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').expect("x,y pair");
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect()
}

pub fn length(line: &Line) -> f64 {
    line.windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum()
}

/// A dash is at most `DASH_PX` long; vertices are rounded to whole pixels, hence the slack.
pub fn is_dash(line: &Line) -> bool {
    length(line) <= f64::from(DASH_PX) + 1.5
}

pub fn is_horizontal_pair(line: &Line) -> bool {
    line.len() == 2 && line[0].1 == line[1].1
}

pub fn is_vertical_pair(line: &Line) -> bool {
    line.len() == 2 && line[0].0 == line[1].0
}

pub fn line(label: &str, x: Vec<f64>, y: Vec<f64>, stable: Option<Vec<bool>>) -> Series {
    Series {
        label: label.into(),
        x,
        y,
        style: Style::Line,
        stable,
        err: None,
    }
}
