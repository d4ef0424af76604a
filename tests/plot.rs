//! Tests of the SVG figures: each writes a figure, parses it as XML and checks what a reader of
//! the figure relies on (labels, legend, dashes, markers, cells), not merely that it was written.
//!
//! The checks lean on how `plotters` 0.3.7 writes SVG (see the `plot` module docs): texts are
//! `<text>` elements holding the string verbatim, a solid curve is one `<polyline>` in the series
//! colour, a dashed curve is one short `<polyline>` per dash (no `stroke-dasharray`).

use std::path::PathBuf;

use helixbif::Error;
use helixbif::plot::{
    DASH_PX, Figure, Heatmap, Marker, MarkerShape, Scale, Series, Style, write_figure,
    write_heatmap, write_panels,
};
use roxmltree::{Document, Node};

/// Okabe–Ito colours of the first series, as the SVG writes them.
const BLUE: &str = "#0072B2";
const VERMILLION: &str = "#D55E00";
const GREEN: &str = "#009E73";
/// Colour of the "unstable (dashed)" legend sample.
const NEUTRAL: &str = "#555555";

fn out(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("plot-{name}.svg"))
}

fn read(name: &str) -> String {
    std::fs::read_to_string(out(name)).expect("figure was written")
}

fn parse(svg: &str) -> Document<'_> {
    Document::parse(svg).expect("the SVG is well-formed XML")
}

fn elements<'a, 'i>(doc: &'a Document<'i>, tag: &str) -> Vec<Node<'a, 'i>> {
    doc.descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == tag)
        .collect()
}

/// The content of every `<text>` element, trimmed.
fn texts(doc: &Document) -> Vec<String> {
    elements(doc, "text")
        .iter()
        .map(|n| n.text().unwrap_or("").trim().to_owned())
        .collect()
}

fn count_text(doc: &Document, wanted: &str) -> usize {
    texts(doc).iter().filter(|t| *t == wanted).count()
}

fn attr(n: &Node, name: &str) -> f64 {
    n.attribute(name)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("<{}> has a numeric {name}", n.tag_name().name()))
}

type Line = Vec<(f64, f64)>;

/// The vertices of every `<polyline>` stroked in `color`.
fn polylines(doc: &Document, color: &str) -> Vec<Line> {
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

fn length(line: &Line) -> f64 {
    line.windows(2)
        .map(|w| (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1))
        .sum()
}

/// A dash is at most `DASH_PX` long; vertices are rounded to whole pixels, hence the slack.
fn is_dash(line: &Line) -> bool {
    length(line) <= f64::from(DASH_PX) + 1.5
}

fn is_horizontal_pair(line: &Line) -> bool {
    line.len() == 2 && line[0].1 == line[1].1
}

fn is_vertical_pair(line: &Line) -> bool {
    line.len() == 2 && line[0].0 == line[1].0
}

fn line(label: &str, x: Vec<f64>, y: Vec<f64>, stable: Option<Vec<bool>>) -> Series {
    Series {
        label: label.into(),
        x,
        y,
        style: Style::Line,
        stable,
        err: None,
    }
}

/// Number of points of a branch, and where each branch loses stability.
const N: usize = 21;
const A_UNSTABLE_FROM: usize = 10;
const B_UNSTABLE_FROM: usize = 14;

fn omega() -> Vec<f64> {
    (0..N).map(|i| i as f64 * 0.5).collect()
}

fn branch_figure() -> Figure {
    let w = omega();
    let stable_until = |k: usize| Some((0..N).map(|i| i < k).collect());
    Figure {
        title: "Whirling branches".into(),
        x_label: "omega (rad/s)".into(),
        y_label: "amplitude (mm)".into(),
        series: vec![
            line(
                "branch A",
                w.clone(),
                w.iter().map(|w| 0.1 * w * w).collect(),
                stable_until(A_UNSTABLE_FROM),
            ),
            Series {
                // Uncertain amplitude: drawn as a shaded band, which does not add polylines.
                err: Some(vec![0.4; N]),
                ..line(
                    "branch B",
                    w.clone(),
                    w.iter().map(|w| 10.0 - 0.5 * w).collect(),
                    stable_until(B_UNSTABLE_FROM),
                )
            },
            Series {
                label: "reference".into(),
                x: vec![0.0, 10.0],
                y: vec![5.0, 5.0],
                style: Style::Dashed,
                stable: None,
                err: None,
            },
        ],
        markers: vec![
            Marker {
                label: "hopf".into(),
                x: 4.75,
                y: 2.26,
            },
            Marker {
                label: "fold".into(),
                x: 6.75,
                y: 6.6,
            },
        ],
        ..Figure::default()
    }
}

/// Checks the runs of one branch drawn in `color` that is stable for its first `k` points.
///
/// How the polylines are counted: the stable run is ONE polyline through points 0..k plus the
/// midpoint to point k (k + 1 vertices); the unstable run is cut into dashes, each its own short
/// polyline; the legend sample is one horizontal two-point polyline longer than a dash. So the
/// colour has exactly two polylines that are not dashes, and the dashes lie right of the solid
/// run (omega increases along the branch) and reach the last point.
fn check_branch(doc: &Document, color: &str, k: usize) {
    let all = polylines(doc, color);
    let (dashes, long): (Vec<&Line>, Vec<&Line>) = all.iter().partition(|l| is_dash(l));
    assert_eq!(
        long.len(),
        2,
        "{color}: one solid run and one legend sample"
    );
    let solid = long
        .iter()
        .find(|l| l.len() > 2)
        .expect("the solid run has many vertices");
    assert_eq!(
        solid.len(),
        k + 1,
        "{color}: stable points plus the midpoint"
    );
    assert!(
        long.iter().any(|l| is_horizontal_pair(l)),
        "{color}: legend sample"
    );

    // omega = 0.5 i maps linearly to pixels; the solid run's first vertex is point 0 and its
    // next-to-last vertex is point k - 1, which fixes the map.
    let (x0, xk) = (solid[0].0, solid[k - 1].0);
    let px_per_point = (xk - x0) / (k - 1) as f64;
    let last_point_px = x0 + px_per_point * (N - 1) as f64;
    let solid_end = solid[k].0;
    assert!(dashes.len() >= 5, "{color}: the unstable run is dashed");
    for dash in &dashes {
        for &(x, _) in dash.iter() {
            assert!(
                x >= solid_end - 1.0 && x <= last_point_px + 1.0,
                "{color}: dash at {x}"
            );
        }
    }
    let reach = dashes
        .iter()
        .flat_map(|d| d.iter().map(|p| p.0))
        .fold(f64::MIN, f64::max);
    let pattern = f64::from(DASH_PX + helixbif::plot::GAP_PX);
    assert!(
        reach >= last_point_px - pattern - 1.0,
        "{color}: dashes reach the last point ({reach} vs {last_point_px})"
    );
}

#[test]
fn branch_figure_has_labels_legend_and_dashed_unstable_runs() {
    write_figure(&branch_figure(), &out("branches")).unwrap();
    let svg = read("branches");
    let doc = parse(&svg);

    for label in ["omega (rad/s)", "amplitude (mm)", "Whirling branches"] {
        assert_eq!(count_text(&doc, label), 1, "text {label:?}");
    }
    // Each legend label once, although each branch is drawn as several runs.
    for label in [
        "branch A",
        "branch B",
        "reference",
        "hopf",
        "fold",
        "unstable (dashed)",
    ] {
        assert_eq!(count_text(&doc, label), 1, "legend entry {label:?}");
    }
    assert!(
        !svg.contains("stroke-dasharray"),
        "plotters draws dashes as separate polylines"
    );

    check_branch(&doc, BLUE, A_UNSTABLE_FROM);
    check_branch(&doc, VERMILLION, B_UNSTABLE_FROM);

    // The Dashed reference line (and its legend sample) consists of dashes only.
    let reference = polylines(&doc, GREEN);
    assert!(reference.len() >= 10);
    assert!(reference.iter().all(is_dash));

    // The "unstable (dashed)" sample is a neutral dashed line.
    let neutral = polylines(&doc, NEUTRAL);
    assert!(neutral.len() >= 2 && neutral.iter().all(is_dash));

    // Branch B's error band: one translucent polygon along the whole branch (both edges).
    let bands: Vec<Node> = elements(&doc, "polygon")
        .into_iter()
        .filter(|n| n.attribute("fill") == Some(VERMILLION))
        .collect();
    assert_eq!(bands.len(), 1);
    assert_eq!(bands[0].attribute("opacity"), Some("0.2"));
    let vertices = bands[0]
        .attribute("points")
        .unwrap()
        .split_whitespace()
        .count();
    assert_eq!(vertices, 2 * N);

    // Special points: a black diamond and a black triangle, each also in the legend.
    let black_polygons = elements(&doc, "polygon")
        .iter()
        .filter(|n| n.attribute("fill") == Some("#000000"))
        .count();
    assert_eq!(black_polygons, 4);
}

#[test]
fn log_log_markers_with_error_bars_and_annotation() {
    let fig = Figure {
        x_label: "frequency (Hz)".into(),
        y_label: "thrust (nN)".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: vec![Series {
            label: "measured".into(),
            // The last three points cannot be shown on log axes (x <= 0, y = 0, NaN) and are
            // skipped; the fourth one's error bar reaches below zero and is cut at the axis.
            x: vec![1.0, 10.0, 100.0, 1000.0, -1.0, 50.0, 20.0],
            y: vec![2.0, 20.0, 100.0, 800.0, 5.0, 0.0, f64::NAN],
            style: Style::Markers(MarkerShape::Circle),
            stable: None,
            err: Some(vec![0.5, 5.0, 50.0, 900.0, 1.0, 1.0, 1.0]),
        }],
        annotation: Some("m = 0.62 ± 0.03\nfit: 2 < f < 1000".into()),
        ..Figure::default()
    };
    write_figure(&fig, &out("loglog")).unwrap();
    let svg = read("loglog");
    let doc = parse(&svg);

    assert_eq!(count_text(&doc, "m = 0.62 ± 0.03"), 1);
    assert_eq!(count_text(&doc, "fit: 2 < f < 1000"), 1);
    for label in ["frequency (Hz)", "thrust (nN)", "1", "10", "100", "1000"] {
        assert!(count_text(&doc, label) >= 1, "text {label:?}");
    }
    // A single series and no special points: no legend.
    assert_eq!(count_text(&doc, "measured"), 0);

    let mut circles: Vec<(f64, f64)> = elements(&doc, "circle")
        .iter()
        .filter(|n| n.attribute("fill") == Some(BLUE))
        .map(|n| (attr(n, "cx"), attr(n, "cy")))
        .collect();
    assert_eq!(circles.len(), 4, "one marker per drawable point");
    circles.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Decades are equally spaced on a log axis.
    let gaps: Vec<f64> = circles.windows(2).map(|w| w[1].0 - w[0].0).collect();
    assert!(gaps.iter().all(|g| (g - gaps[0]).abs() <= 1.0), "{gaps:?}");

    let lines = polylines(&doc, BLUE);
    let bars: Vec<&Line> = lines.iter().filter(|l| is_vertical_pair(l)).collect();
    let caps: Vec<&Line> = lines.iter().filter(|l| is_horizontal_pair(l)).collect();
    assert_eq!(bars.len(), 4);
    // Two caps per bar, except at the lower end of 800 ± 900, which is cut at the axis.
    assert_eq!(caps.len(), 7);
    let (cut_x, _) = circles[3];
    let cut_bar = bars
        .iter()
        .find(|b| b[0].0 == cut_x)
        .expect("bar of 800 ± 900");
    let cut_bottom = cut_bar[0].1.max(cut_bar[1].1);
    assert!(
        !caps
            .iter()
            .any(|c| c[0].1 == cut_bottom && (c[0].0 - cut_x).abs() < 10.0)
    );

    // 100 ± 50 on a log axis: the bar reaches ln(1.5)/ln(2) as far up as down.
    let (cx, cy) = circles[2];
    let bar = bars
        .iter()
        .find(|b| b[0].0 == cx)
        .expect("bar through the marker");
    let (top, bottom) = (bar[0].1.min(bar[1].1), bar[0].1.max(bar[1].1));
    let ratio = (cy - top) / (bottom - cy);
    assert!(
        (ratio - 1.5f64.ln() / 2f64.ln()).abs() < 0.05,
        "ratio {ratio}"
    );
}

fn phase_diagram(nan_cells: &[(usize, usize)]) -> Heatmap {
    let x: Vec<f64> = (0..10).map(f64::from).collect();
    let y: Vec<f64> = (0..6).map(|i| f64::from(i) * 0.2).collect();
    let mut z: Vec<Vec<f64>> = y
        .iter()
        .map(|yi| x.iter().map(|xj| xj * yi).collect())
        .collect();
    for &(i, j) in nan_cells {
        z[i][j] = f64::NAN;
    }
    Heatmap {
        title: "Stability map".into(),
        x_label: "omega (rad/s)".into(),
        y_label: "stiffness ratio".into(),
        colorbar_label: "growth rate (1/s)".into(),
        x: x.clone(),
        y,
        z,
        overlays: vec![
            line(
                "boundary",
                x.clone(),
                x.iter().map(|xi| 1.0 - 0.08 * xi).collect(),
                None,
            ),
            Series {
                label: "observed".into(),
                x: vec![3.0, 6.0],
                y: vec![0.5, 0.3],
                style: Style::Markers(MarkerShape::Square),
                stable: None,
                err: Some(vec![0.1, 0.05]),
            },
        ],
    }
}

/// `<rect>`s filled with an opaque colour other than the white background.
fn filled_rects(doc: &Document) -> Vec<String> {
    elements(doc, "rect")
        .iter()
        .filter(|n| n.attribute("opacity") == Some("1"))
        .filter_map(|n| n.attribute("fill"))
        .filter(|fill| *fill != "none" && *fill != "#FFFFFF")
        .map(str::to_owned)
        .collect()
}

#[test]
fn heatmap_has_cells_colorbar_and_overlays() {
    let nan = [(2, 3), (5, 9)];
    write_heatmap(&phase_diagram(&nan), &out("heatmap-nan")).unwrap();
    write_heatmap(&phase_diagram(&[]), &out("heatmap")).unwrap();
    let (with_nan, full) = (read("heatmap-nan"), read("heatmap"));
    let (with_nan, full) = (parse(&with_nan), parse(&full));

    for label in [
        "growth rate (1/s)",
        "omega (rad/s)",
        "stiffness ratio",
        "Stability map",
        "boundary",
        "observed",
    ] {
        assert_eq!(count_text(&with_nan, label), 1, "text {label:?}");
    }
    let cells = 10 * 6;
    let (filled_nan, filled_full) = (filled_rects(&with_nan), filled_rects(&full));
    assert!(filled_nan.len() >= cells - nan.len());
    assert!(filled_full.len() >= cells);
    // NaN cells are left blank and nothing else changes.
    assert_eq!(filled_full.len() - filled_nan.len(), nan.len());
    // The smallest and largest values get the two ends of viridis.
    assert!(filled_full.iter().any(|f| f == "#440154"));
    assert!(filled_full.iter().any(|f| f == "#FDE725"));

    // The boundary overlay is one solid polyline through its ten points (the first overlay
    // colour is vermillion, absent from viridis).
    let boundary = polylines(&with_nan, VERMILLION);
    assert!(boundary.iter().any(|l| l.len() == 10));
}

fn view(title: &str, x_label: &str, y_label: &str) -> Figure {
    let s: Vec<f64> = (0..50).map(|i| f64::from(i) / 49.0).collect();
    Figure {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        series: vec![line(
            "centreline",
            s.iter().map(|s| (6.0 * s).cos() * 0.2).collect(),
            s.clone(),
            None,
        )],
        ..Figure::default()
    }
}

#[test]
fn panels_sit_side_by_side_with_their_own_axes() {
    let panels = [
        view("front view", "x (mm)", "z (mm)"),
        view("side view", "y (mm)", "z (mm) side"),
    ];
    write_panels(&panels, &out("panels"), (1200, 500)).unwrap();
    let svg = read("panels");
    let doc = parse(&svg);
    assert_eq!(doc.root_element().attribute("width"), Some("1200"));

    let x_of = |label: &str| {
        let node = elements(&doc, "text")
            .into_iter()
            .find(|n| n.text().map(str::trim) == Some(label))
            .unwrap_or_else(|| panic!("text {label:?}"));
        attr(&node, "x")
    };
    for label in ["front view", "x (mm)", "z (mm)"] {
        assert!(x_of(label) < 600.0, "{label:?} is in the left panel");
    }
    for label in ["side view", "y (mm)", "z (mm) side"] {
        assert!(x_of(label) > 600.0, "{label:?} is in the right panel");
    }
    // Each panel draws its own curve.
    assert_eq!(polylines(&doc, BLUE).len(), 2);
}

#[test]
fn degenerate_data_give_valid_figures() {
    let nan = f64::NAN;
    let series = |x: Vec<f64>, y: Vec<f64>| line("s", x, y, None);
    let figures = [
        ("nothing", Figure::default()),
        (
            "empty",
            Figure {
                series: vec![series(vec![], vec![]), series(vec![], vec![])],
                markers: vec![Marker {
                    label: "fold".into(),
                    x: nan,
                    y: 1.0,
                }],
                annotation: Some(String::new()),
                ..Figure::default()
            },
        ),
        (
            "all-nan",
            Figure {
                series: vec![series(vec![nan, nan], vec![nan, f64::INFINITY])],
                ..Figure::default()
            },
        ),
        (
            "constant",
            Figure {
                series: vec![series(vec![1.0; 5], vec![3.0; 5])],
                ..Figure::default()
            },
        ),
        (
            "log-non-positive",
            Figure {
                x_scale: Scale::Log,
                y_scale: Scale::Log,
                series: vec![series(vec![0.0, -1.0], vec![1.0, 2.0])],
                ..Figure::default()
            },
        ),
        (
            "extreme",
            Figure {
                series: vec![
                    series(vec![-f64::MAX, f64::MAX], vec![f64::MAX, -f64::MAX]),
                    Series {
                        style: Style::Markers(MarkerShape::Cross),
                        stable: Some(vec![false]),
                        err: Some(vec![f64::INFINITY]),
                        ..series(vec![0.0], vec![f64::MIN_POSITIVE])
                    },
                ],
                ..Figure::default()
            },
        ),
    ];
    for (name, fig) in &figures {
        write_figure(fig, &out(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        parse(&read(name));
    }

    // Constant values: the axis is widened around the value, which gets a tick label.
    let constant = read("constant");
    let doc = parse(&constant);
    let ticks: Vec<f64> = texts(&doc).iter().filter_map(|t| t.parse().ok()).collect();
    assert!(ticks.iter().any(|&t| t < 3.0) && ticks.iter().any(|&t| t > 3.0));
    assert!(ticks.contains(&3.0));

    // A lone point of a line series is still drawn, as a dot.
    let single = Figure {
        series: vec![series(vec![2.0, nan], vec![1.0, 4.0])],
        ..Figure::default()
    };
    write_figure(&single, &out("single")).unwrap();
    let single = read("single");
    let doc = parse(&single);
    let dots = elements(&doc, "circle")
        .iter()
        .filter(|n| n.attribute("fill") == Some(BLUE))
        .count();
    assert_eq!(dots, 1);

    let maps = [
        ("map-empty", Heatmap::default()),
        (
            "map-all-nan",
            Heatmap {
                x: vec![0.0, 1.0],
                y: vec![0.0],
                z: vec![vec![nan, nan]],
                ..Heatmap::default()
            },
        ),
        (
            "map-single",
            Heatmap {
                x: vec![5.0],
                y: vec![0.0],
                z: vec![vec![2.0]],
                overlays: vec![series(vec![], vec![])],
                ..Heatmap::default()
            },
        ),
        (
            "map-constant",
            Heatmap {
                x: vec![0.0, 1.0, 2.0],
                y: vec![2.0, 1.0],
                z: vec![vec![7.0; 3]; 2],
                ..Heatmap::default()
            },
        ),
    ];
    for (name, map) in &maps {
        write_heatmap(map, &out(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        parse(&read(name));
    }

    write_panels(
        &[figures[1].1.clone(), figures[2].1.clone()],
        &out("panels-degenerate"),
        (800, 300),
    )
    .unwrap();
    parse(&read("panels-degenerate"));
}

#[test]
fn malformed_input_is_an_input_error_and_bad_paths_an_io_error() {
    let short = Figure {
        series: vec![line("s", vec![1.0, 2.0], vec![1.0], None)],
        ..Figure::default()
    };
    assert!(write_figure(&short, &out("short")).unwrap_err().is_input());
    let mask = Figure {
        series: vec![line("s", vec![1.0, 2.0], vec![1.0, 2.0], Some(vec![true]))],
        ..Figure::default()
    };
    assert!(write_figure(&mask, &out("mask")).unwrap_err().is_input());

    let ragged = Heatmap {
        x: vec![0.0, 1.0],
        y: vec![0.0, 1.0],
        z: vec![vec![1.0, 2.0], vec![3.0]],
        ..Heatmap::default()
    };
    assert!(
        write_heatmap(&ragged, &out("ragged"))
            .unwrap_err()
            .is_input()
    );
    let unsorted = Heatmap {
        x: vec![0.0, 2.0, 1.0],
        y: vec![0.0],
        z: vec![vec![1.0; 3]],
        ..Heatmap::default()
    };
    assert!(
        write_heatmap(&unsorted, &out("unsorted"))
            .unwrap_err()
            .is_input()
    );

    assert!(
        write_panels(&[], &out("none"), (800, 600))
            .unwrap_err()
            .is_input()
    );
    let two = [Figure::default(), Figure::default()];
    assert!(
        write_panels(&two, &out("tiny"), (300, 600))
            .unwrap_err()
            .is_input()
    );

    let missing = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("no-such-dir/figure.svg");
    match write_figure(&Figure::default(), &missing) {
        Err(Error::Io { path, .. }) => assert!(path.ends_with("figure.svg")),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

/// Data in every corner of the plot area and none at the middle of its left side (a branch
/// across the top and a collapsed branch along the bottom): the legend goes to the middle of
/// the left side, where it hides nothing.
#[test]
fn a_legend_that_would_hide_data_in_every_corner_goes_to_the_middle_of_a_side() {
    let line = |label: &str, y: f64| Series {
        label: label.into(),
        x: (0..=40).map(|i| i as f64 / 40.0).collect(),
        y: vec![y; 41],
        style: Style::Line,
        stable: None,
        err: None,
    };
    write_figure(
        &Figure {
            title: "corners taken".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![line("top", 1.0), line("bottom", 0.0)],
            ..Figure::default()
        },
        &out("legend-middle"),
    )
    .unwrap();
    let svg = read("legend-middle");
    let doc = parse(&svg);
    let position = |label: &str| {
        let n = elements(&doc, "text")
            .into_iter()
            .find(|n| n.text().unwrap_or("").trim() == label)
            .unwrap_or_else(|| panic!("text {label:?}"));
        (attr(&n, "x"), attr(&n, "y"))
    };
    // The data lines' heights in pixels: their polylines in the first two series colours.
    let height = |color: &str| {
        polylines(&doc, color)
            .into_iter()
            .max_by_key(|l| l.len())
            .map(|l| l[0].1)
            .unwrap()
    };
    let (top, bottom) = (height(BLUE), height(VERMILLION));
    let (x_top, y_top) = position("top");
    let (_, y_bottom) = position("bottom");
    let third = (bottom - top) / 3.0;
    assert!(
        y_top > top + third && y_bottom < bottom - third,
        "legend rows at {y_top}, {y_bottom}; data at {top} and {bottom}"
    );
    let (x_label, _) = position("x");
    assert!(
        x_top < x_label,
        "legend at x = {x_top}, the middle at {x_label}"
    );
}
