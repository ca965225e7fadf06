//! The one font of figures and frame overlays: DejaVu Sans, embedded by the
//! `dejavu` crate, so no system font is needed.

use std::sync::Once;

use plotters::style::FontStyle;

static FONT: Once = Once::new();

/// Registers DejaVu Sans as plotters' `sans-serif` (once per process).
pub(crate) fn register_font() {
    FONT.call_once(|| {
        // The bytes are embedded by the `dejavu` crate, so no system font is needed.
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| unreachable!("the embedded DejaVu Sans is a valid font"));
    });
}
