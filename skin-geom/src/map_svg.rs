//! A tactile map drawn as SVG.

use crate::tactile_map::TactileMap;
use nalgebra::Point2;

impl TactileMap {
    /// An SVG drawing of the map (millimetres): triangles, and a dot per taxel.
    pub fn to_svg(&self) -> String {
        use std::fmt::Write as _;
        let (lo, hi) = self.bounds();
        let margin = 5.0;
        let mm = |v: f64| v * 1e3;
        let (w, h) = (mm(hi.x - lo.x) + 2.0 * margin, mm(hi.y - lo.y) + 2.0 * margin);
        // SVG's y axis points down: flip v so the drawing is the map as seen from outside.
        let x = |p: &Point2<f64>| mm(p.x - lo.x) + margin;
        let y = |p: &Point2<f64>| mm(hi.y - p.y) + margin;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.1}mm" height="{h:.1}mm" viewBox="0 0 {w:.2} {h:.2}">"#
        );
        let _ = writeln!(
            s,
            r#"<title>tactile map {} ({} taxels, {} triangles)</title>"#,
            self.name,
            self.ids.len(),
            self.faces.len()
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(s, r##"<g fill="#dde8f5" stroke="#4a6fa5" stroke-width="0.2">"##);
        for f in &self.faces {
            let p = f.map(|t| self.points[t]);
            let _ = writeln!(
                s,
                r#"<polygon points="{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}"/>"#,
                x(&p[0]),
                y(&p[0]),
                x(&p[1]),
                y(&p[1]),
                x(&p[2]),
                y(&p[2])
            );
        }
        let _ = writeln!(s, "</g>");
        let _ = writeln!(s, r##"<g fill="#c0392b">"##);
        for (p, id) in self.points.iter().zip(&self.ids) {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.2}" cy="{:.2}" r="1.2"><title>taxel {id}</title></circle>"#,
                x(p),
                y(p)
            );
        }
        let _ = writeln!(s, "</g>\n</svg>");
        s
    }
}
