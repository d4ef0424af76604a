//! The PNG of a figure: its SVG rendered by `resvg` with the embedded font (see the module docs
//! of `plot` for why this path).

use std::path::Path;
use std::sync::{Arc, OnceLock};

use resvg::tiny_skia::{Color, Pixmap, Transform};
use resvg::usvg::{self, fontdb};

use super::style::{FONT_NAME, FONT_TTF, PNG_SCALE};
use crate::{Error, Result};

/// The font database of every rendering: the embedded font alone, standing for every generic
/// family, so nothing depends on the fonts of the machine.
fn fonts() -> Arc<fontdb::Database> {
    static FONTS: OnceLock<Arc<fontdb::Database>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut db = fontdb::Database::new();
            db.load_font_data(FONT_TTF.to_vec());
            db.set_sans_serif_family(FONT_NAME);
            db.set_serif_family(FONT_NAME);
            db.set_monospace_family(FONT_NAME);
            Arc::new(db)
        })
        .clone()
}

/// The PNG image of `svg`, [`PNG_SCALE`] pixels per SVG pixel, on white.
pub(crate) fn encode(svg: &str) -> Result<Vec<u8>> {
    let failed = |what: &str, e: &dyn std::fmt::Display| {
        Error::Numerical(format!("rendering the figure as PNG failed: {what}: {e}"))
    };
    let options = usvg::Options {
        font_family: FONT_NAME.to_owned(),
        fontdb: fonts(),
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_str(svg, &options).map_err(|e| failed("parsing the SVG", &e))?;
    let size = tree.size().to_int_size();
    let (w, h) = (size.width() * PNG_SCALE, size.height() * PNG_SCALE);
    let mut pixmap = Pixmap::new(w, h).ok_or_else(|| failed("image size", &format!("{w}x{h}")))?;
    pixmap.fill(Color::WHITE);
    let scale = PNG_SCALE as f32;
    resvg::render(
        &tree,
        Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    pixmap
        .encode_png()
        .map_err(|e| failed("encoding the PNG", &e))
}

/// Writes the PNG of `svg` to `path`.
pub(crate) fn write(svg: &str, path: &Path) -> Result<()> {
    let png = encode(svg)?;
    std::fs::write(path, png).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })
}
