//! Layout checks of a drawn figure: a drawing backend that draws nothing but records
//! where everything would go, so tests can check that nothing is drawn outside the
//! canvas, that no two text labels overlap and that no text lies on the data
//! (`tests/figures.rs`, through [`crate::plot::figure::Figure::inspect`]).
//!
//! Data marks are the lines, paths and markers drawn in a colour (axes, grid lines and
//! ticks are grey or black); a text box crossed by one covers data.
//!
//! Text boxes are the ones the bitmap backend fills: the font's layout box of the
//! string, placed by its anchor and rotated as drawn.
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind, FontTransform};
use std::cell::RefCell;
use std::rc::Rc;

/// One drawn text: its string and its box `(x0, y0, x1, y1)` in canvas units.
#[derive(Debug, Clone, PartialEq)]
pub struct TextBox {
    pub text: String,
    pub rect: (i32, i32, i32, i32),
}

/// What a figure drew, and where.
#[derive(Debug, Clone, Default)]
pub struct Record {
    pub size: (u32, u32),
    pub texts: Vec<TextBox>,
    /// Segments of the data marks (lines, paths, marker boxes in a colour).
    pub data: Vec<(BackendCoord, BackendCoord)>,
    /// Primitives (or texts) reaching outside the canvas, described.
    pub outside: Vec<String>,
    /// Plotting areas of the colour maps `(x0, y0, x1, y1)`, in drawing order (filled in
    /// by [`crate::plot::figure::Figure::inspect`]).
    pub maps: Vec<(i32, i32, i32, i32)>,
}

impl Record {
    /// Every problem found: primitives outside the canvas, overlapping text pairs, texts
    /// lying on data marks or on a map, then maps overlapping each other.
    pub fn problems(&self) -> Vec<String> {
        let mut out = self.outside.clone();
        for (i, a) in self.texts.iter().enumerate() {
            for b in &self.texts[i + 1..] {
                if overlap(a.rect, b.rect) {
                    out.push(format!("text `{}` {:?} overlaps `{}` {:?}", a.text, a.rect, b.text, b.rect));
                }
            }
        }
        for t in &self.texts {
            if let Some(seg) = self.data.iter().find(|&&(p, q)| crosses(t.rect, p, q)) {
                out.push(format!("text `{}` {:?} lies on data drawn from {:?} to {:?}", t.text, t.rect, seg.0, seg.1));
            }
            if let Some(m) = self.maps.iter().find(|&&m| overlap(t.rect, m)) {
                out.push(format!("text `{}` {:?} lies on the map at {m:?}", t.text, t.rect));
            }
        }
        for (i, a) in self.maps.iter().enumerate() {
            for b in &self.maps[i + 1..] {
                if overlap(*a, *b) {
                    out.push(format!("map {a:?} overlaps map {b:?}"));
                }
            }
        }
        out
    }
}

/// Whether two boxes share more than a one-unit sliver.
fn overlap(a: (i32, i32, i32, i32), b: (i32, i32, i32, i32)) -> bool {
    let w = a.2.min(b.2) - a.0.max(b.0);
    let h = a.3.min(b.3) - a.1.max(b.1);
    w > 1 && h > 1
}

/// Whether the segment p–q passes through the inside of a box (shrunk by one unit, so
/// a mark touching a label's edge does not count).
fn crosses(rect: (i32, i32, i32, i32), p: BackendCoord, q: BackendCoord) -> bool {
    let (x0, y0, x1, y1) = (rect.0 as f64 + 1.0, rect.1 as f64 + 1.0, rect.2 as f64 - 1.0, rect.3 as f64 - 1.0);
    if x0 >= x1 || y0 >= y1 {
        return false;
    }
    // Liang–Barsky clipping of the segment against the box.
    let (px, py, dx, dy) = (p.0 as f64, p.1 as f64, (q.0 - p.0) as f64, (q.1 - p.1) as f64);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (d, e) in [(-dx, px - x0), (dx, x1 - px), (-dy, py - y0), (dy, y1 - py)] {
        if d == 0.0 {
            if e < 0.0 {
                return false;
            }
        } else {
            let t = e / d;
            if d < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    t0 < t1
}

/// A colour that marks data: any but black (axes, ticks) and the light greys and white
/// of grid lines and backgrounds (the palette's mid grey is a data colour). Rectangles,
/// polygons and bitmaps (bars, colour bars, maps) are not recorded as data marks.
fn is_data_colour(c: BackendColor) -> bool {
    let (r, g, b) = c.rgb;
    c.alpha > 0.0 && !(r == g && g == b && !(40..=200).contains(&r))
}

/// The backend: cheap (nothing is rasterised), shared with the caller through an `Rc`.
pub struct Recorder {
    record: Rc<RefCell<Record>>,
}

impl Recorder {
    pub fn new(size: (u32, u32)) -> (Self, Rc<RefCell<Record>>) {
        let record = Rc::new(RefCell::new(Record { size, ..Default::default() }));
        (Recorder { record: record.clone() }, record)
    }

    fn check(&self, what: &str, points: &[BackendCoord]) {
        let (w, h) = self.record.borrow().size;
        // one unit of slack: a line on the last pixel row is inside
        let inside = |&(x, y): &BackendCoord| x >= -1 && y >= -1 && x <= w as i32 + 1 && y <= h as i32 + 1;
        if let Some(p) = points.iter().find(|p| !inside(p)) {
            self.record.borrow_mut().outside.push(format!("{what} at {p:?} outside the {w}×{h} canvas"));
        }
    }
}

#[derive(Debug)]
pub struct Never;
impl std::fmt::Display for Never {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("never")
    }
}
impl std::error::Error for Never {}

impl DrawingBackend for Recorder {
    type ErrorType = Never;

    fn get_size(&self) -> (u32, u32) {
        self.record.borrow().size
    }
    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Never>> {
        Ok(())
    }
    fn present(&mut self) -> Result<(), DrawingErrorKind<Never>> {
        Ok(())
    }
    fn draw_pixel(&mut self, point: BackendCoord, _: BackendColor) -> Result<(), DrawingErrorKind<Never>> {
        self.check("pixel", &[point]);
        Ok(())
    }
    fn draw_line<S: BackendStyle>(&mut self, from: BackendCoord, to: BackendCoord, style: &S) -> Result<(), DrawingErrorKind<Never>> {
        self.check("line", &[from, to]);
        if is_data_colour(style.color()) {
            self.record.borrow_mut().data.push((from, to));
        }
        Ok(())
    }
    fn draw_rect<S: BackendStyle>(&mut self, ul: BackendCoord, br: BackendCoord, _: &S, _: bool) -> Result<(), DrawingErrorKind<Never>> {
        self.check("rectangle", &[ul, br]);
        Ok(())
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(&mut self, path: I, style: &S) -> Result<(), DrawingErrorKind<Never>> {
        let points: Vec<BackendCoord> = path.into_iter().collect();
        self.check("path", &points);
        if is_data_colour(style.color()) {
            self.record.borrow_mut().data.extend(points.windows(2).map(|w| (w[0], w[1])));
        }
        Ok(())
    }
    fn draw_circle<S: BackendStyle>(&mut self, c: BackendCoord, r: u32, style: &S, _: bool) -> Result<(), DrawingErrorKind<Never>> {
        let r = r as i32;
        self.check("circle", &[(c.0 - r, c.1 - r), (c.0 + r, c.1 + r)]);
        if is_data_colour(style.color()) {
            // A marker: its horizontal and vertical diameters.
            self.record.borrow_mut().data.extend([((c.0 - r, c.1), (c.0 + r, c.1)), ((c.0, c.1 - r), (c.0, c.1 + r))]);
        }
        Ok(())
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(&mut self, vert: I, _: &S) -> Result<(), DrawingErrorKind<Never>> {
        self.check("polygon", &vert.into_iter().collect::<Vec<_>>());
        Ok(())
    }
    fn draw_text<T: BackendTextStyle>(&mut self, text: &str, style: &T, pos: BackendCoord) -> Result<(), DrawingErrorKind<Never>> {
        if text.trim().is_empty() || style.color().alpha == 0.0 {
            return Ok(());
        }
        let Ok(((x0, y0), (x1, y1))) = style.layout_box(text) else {
            return Ok(());
        };
        let rect = text_rect(x1 - x0, y1 - y0, style.anchor().h_pos, style.anchor().v_pos, style.transform(), pos);
        self.check(&format!("text `{text}`"), &[(rect.0, rect.1), (rect.2, rect.3)]);
        self.record.borrow_mut().texts.push(TextBox { text: text.to_string(), rect });
        Ok(())
    }
    fn blit_bitmap(&mut self, pos: BackendCoord, (w, h): (u32, u32), _: &[u8]) -> Result<(), DrawingErrorKind<Never>> {
        self.check("bitmap", &[pos, (pos.0 + w as i32, pos.1 + h as i32)]);
        Ok(())
    }
}

/// The box a text of layout size `w × h` fills when drawn at `pos` with this anchor and
/// rotation (as `plotters_backend::DrawingBackend::draw_text` places it).
fn text_rect(w: i32, h: i32, hp: HPos, vp: VPos, t: FontTransform, pos: BackendCoord) -> (i32, i32, i32, i32) {
    let dx = match hp {
        HPos::Left => 0,
        HPos::Right => -w,
        HPos::Center => -w / 2,
    };
    let dy = match vp {
        VPos::Top => 0,
        VPos::Center => -h / 2,
        VPos::Bottom => -h,
    };
    let corners = [(dx, dy), (dx + w, dy), (dx, dy + h), (dx + w, dy + h)].map(|(x, y)| t.transform(x, y));
    let xs = corners.map(|c| c.0);
    let ys = corners.map(|c| c.1);
    let (min, max) = (|a: [i32; 4]| *a.iter().min().unwrap(), |a: [i32; 4]| *a.iter().max().unwrap());
    (pos.0 + min(xs), pos.1 + min(ys), pos.0 + max(xs), pos.1 + max(ys))
}

/// Draw with `draw` onto a recording canvas of `size` and return what was recorded.
pub fn record<F>(size: (u32, u32), draw: F) -> anyhow::Result<Record>
where
    F: FnOnce(&DrawingArea<Recorder, Shift>) -> anyhow::Result<()>,
{
    let (backend, record) = Recorder::new(size);
    {
        let root = backend.into_drawing_area();
        draw(&root)?;
    }
    let r = record.borrow().clone();
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlapping_and_outside_texts_are_found() {
        crate::plot::figure::ensure_font_for_tests();
        let r = record((200, 100), |root| {
            let style = ("sans-serif", 14.0).into_font();
            root.draw(&Text::new("first label", (10, 10), style.clone())).unwrap();
            root.draw(&Text::new("second", (30, 12), style.clone())).unwrap();
            root.draw(&Text::new("far right", (190, 50), style.clone())).unwrap();
            root.draw(&Text::new("apart", (10, 70), style)).unwrap();
            Ok(())
        })
        .unwrap();
        let p = r.problems();
        assert_eq!(p.len(), 2, "{p:?}");
        assert!(p[0].contains("far right") && p[0].contains("outside"), "{p:?}");
        assert!(p[1].contains("first label") && p[1].contains("second"), "{p:?}");
    }

    #[test]
    fn text_on_a_data_line_is_found_and_grey_axes_are_not_data() {
        crate::plot::figure::ensure_font_for_tests();
        let r = record((200, 100), |root| {
            let style = ("sans-serif", 14.0).into_font();
            root.draw(&PathElement::new(vec![(0, 50), (200, 50)], BLUE)).unwrap(); // a data line
            root.draw(&PathElement::new(vec![(0, 20), (200, 20)], BLACK)).unwrap(); // an axis
            root.draw(&Circle::new((180, 90), 3, RED.filled())).unwrap(); // a marker
            root.draw(&Text::new("legend on the line", (10, 44), style.clone())).unwrap(); // top-left anchored: spans y = 50
            root.draw(&Text::new("on the axis", (10, 14), style.clone())).unwrap();
            root.draw(&Text::new("beside", (60, 80), style)).unwrap();
            Ok(())
        })
        .unwrap();
        assert_eq!(r.data.len(), 3, "one path segment and the marker's two diameters: {:?}", r.data);
        let p = r.problems();
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(p[0].contains("legend on the line") && p[0].contains("lies on data"), "{p:?}");
        assert!(crosses((0, 0, 10, 10), (-5, 5), (15, 5)) && !crosses((0, 0, 10, 10), (-5, 20), (15, 20)) && !crosses((0, 0, 10, 10), (10, -5), (10, 15)));
    }

    #[test]
    fn text_on_a_map_and_overlapping_maps_are_found() {
        crate::plot::figure::ensure_font_for_tests();
        let mut r = record((200, 100), |root| {
            let style = ("sans-serif", 14.0).into_font();
            root.draw(&Text::new("on the map", (20, 20), style.clone())).unwrap();
            root.draw(&Text::new("under it", (20, 75), style)).unwrap();
            Ok(())
        })
        .unwrap();
        r.maps = vec![(10, 10, 90, 60), (120, 10, 190, 60)];
        let p = r.problems();
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(p[0].contains("on the map") && p[0].contains("lies on the map"), "{p:?}");
        r.maps.push((80, 50, 130, 90));
        assert_eq!(r.problems().iter().filter(|p| p.contains("overlaps map")).count(), 2, "{:?}", r.problems());
    }

    #[test]
    fn rotated_text_boxes_turn_with_the_text() {
        assert_eq!(text_rect(40, 10, HPos::Center, VPos::Center, FontTransform::None, (100, 100)), (80, 95, 120, 105));
        let r = text_rect(40, 10, HPos::Center, VPos::Center, FontTransform::Rotate270, (100, 100));
        assert_eq!((r.2 - r.0, r.3 - r.1), (10, 40));
    }
}
