//! The stitched maps drawn as SVG.

use super::Placement;
use crate::tactile_map::TactileMap;

/// An SVG drawing of `maps` placed by `placements` (one colour per link, millimetres): what
/// `skin stitch --svg` writes per posture.
pub fn stitched_svg(maps: &[TactileMap], placements: &[Placement]) -> String {
    use std::fmt::Write as _;
    let colours = [
        "#3182bd", "#e6550d", "#31a354", "#756bb1", "#636363", "#d6616b", "#8c6d31",
    ];
    let placed: Vec<Vec<nalgebra::Point2<f64>>> = maps
        .iter()
        .zip(placements)
        .map(|(m, p)| m.points.iter().map(|q| p.apply(q) * 1e3).collect())
        .collect();
    let (mut lo, mut hi) = (
        nalgebra::Point2::new(f64::INFINITY, f64::INFINITY),
        nalgebra::Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    for p in placed.iter().flatten() {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let m = 5.0;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"{:.1} {:.1} {:.1} {:.1}\" width=\"{:.0}mm\" height=\"{:.0}mm\">\n",
        lo.x - m,
        lo.y - m,
        hi.x - lo.x + 2.0 * m,
        hi.y - lo.y + 2.0 * m,
        hi.x - lo.x + 2.0 * m,
        hi.y - lo.y + 2.0 * m
    );
    for (k, (map, pts)) in maps.iter().zip(&placed).enumerate() {
        let colour = colours[k % colours.len()];
        let _ = writeln!(
            s,
            "<g fill=\"{colour}\" fill-opacity=\"0.25\" stroke=\"{colour}\" stroke-width=\"0.2\"><title>{}</title>",
            map.name
        );
        for f in &map.faces {
            let [a, b, c] = f.map(|i| pts[i]);
            let _ = writeln!(
                s,
                "<polygon points=\"{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}\"/>",
                a.x, a.y, b.x, b.y, c.x, c.y
            );
        }
        s.push_str("</g>\n");
    }
    s.push_str("</svg>\n");
    s
}
