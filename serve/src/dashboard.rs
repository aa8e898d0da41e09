//! The dashboard: one HTML page served by the binary, with the vendored charting library
//! (uPlot, `serve/assets/`, no CDN).

/// The page.
pub const PAGE: &str = include_str!("../assets/dashboard.html");

/// A vendored asset by name, with its content type.
pub fn asset(name: &str) -> Option<(&'static str, &'static str)> {
    match name {
        "uPlot.iife.min.js" => Some((
            include_str!("../assets/uPlot.iife.min.js"),
            "text/javascript; charset=utf-8",
        )),
        "uPlot.min.css" => Some((
            include_str!("../assets/uPlot.min.css"),
            "text/css; charset=utf-8",
        )),
        _ => None,
    }
}
