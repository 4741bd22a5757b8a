//! Figure files: PNG with its resolution (pHYs) and provenance (tEXt), SVG with its
//! print size and provenance (`<metadata>`, a comment), and PDF converted from the SVG
//! (`svg2pdf`, font embedded and subset) with provenance in its document information.
//!
//! Provenance is the archive's path and `stage@vN`, so a figure found on its own says
//! where its numbers are.
use super::figure::Provenance;
use anyhow::{anyhow, Context, Result};
use std::path::Path;

/// What every figure file carries besides the picture.
pub struct Metadata {
    pub title: String,
    pub provenance: Provenance,
}

impl Metadata {
    fn software() -> String {
        format!("laydown {}", env!("CARGO_PKG_VERSION"))
    }
    /// Key-value pairs, in the order written.
    fn pairs(&self) -> [(&'static str, String); 4] {
        [
            ("Title", self.title.clone()),
            ("Source", format!("{} {}", self.provenance.archive, self.provenance.stage)),
            ("Software", Self::software()),
            ("Comment", format!("archive: {}; stage: {}", self.provenance.archive, self.provenance.stage)),
        ]
    }
}

/// Write an RGB buffer as PNG, its pixel density set to `dpi` and the provenance in text chunks.
pub fn write_png(path: &Path, rgb: &[u8], size: (u32, u32), dpi: f64, meta: &Metadata) -> Result<()> {
    let file = std::fs::File::create(path).with_context(|| format!("writing {}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), size.0, size.1);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let per_metre = (dpi / 0.0254).round() as u32;
    enc.set_pixel_dims(Some(png::PixelDimensions { xppu: per_metre, yppu: per_metre, unit: png::Unit::Meter }));
    for (key, value) in meta.pairs() {
        // tEXt holds Latin-1; anything else goes into an international (UTF-8) chunk
        if value.chars().all(|c| (c as u32) < 256) {
            enc.add_text_chunk(key.into(), value)?;
        } else {
            enc.add_itxt_chunk(key.into(), value)?;
        }
    }
    let mut w = enc.write_header().with_context(|| format!("writing {}", path.display()))?;
    w.write_image_data(rgb).with_context(|| format!("writing {}", path.display()))?;
    w.finish().with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The SVG that plotters wrote, sized in points for print (`page`, width × height) and
/// with its provenance in `<title>`, `<metadata>` and a comment.
pub fn svg_with_metadata(svg: &str, page: (f64, f64), meta: &Metadata) -> String {
    let Some(start) = svg.find("<svg") else { return svg.to_string() };
    let Some(end) = svg[start..].find('>').map(|e| start + e + 1) else { return svg.to_string() };
    let open = &svg[start..end];
    // plotters writes width="W" height="H" in canvas units: the page size in points instead
    let mut sized = String::new();
    let mut rest = open;
    for (attr, value) in [("width=\"", page.0), ("height=\"", page.1)] {
        if let Some(i) = rest.find(attr) {
            let j = i + attr.len();
            let k = rest[j..].find('"').map(|k| j + k).unwrap_or(j);
            sized.push_str(&rest[..j]);
            sized.push_str(&format!("{value:.2}pt"));
            rest = &rest[k..];
        }
    }
    sized.push_str(rest);
    let pairs: String = meta.pairs().iter().map(|(k, v)| format!("<laydown:{} xmlns:laydown=\"urn:laydown:figure\">{}</laydown:{}>", k.to_lowercase(), xml_escape(v), k.to_lowercase())).collect();
    let (archive, stage) = (xml_escape(&meta.provenance.archive), xml_escape(&meta.provenance.stage));
    format!(
        "{}{}\n<!-- laydown figure; archive: {}; stage: {} -->\n<title>{}</title>\n<metadata>{}</metadata>{}",
        &svg[..start],
        sized,
        archive.replace("--", "- -"),
        stage.replace("--", "- -"),
        xml_escape(&meta.title),
        pairs,
        &svg[end..]
    )
}

/// A one-page PDF of the SVG, `page` points large, text in `font` (embedded), with the
/// provenance in its document information dictionary.
pub fn pdf_from_svg(svg: &str, page: (f64, f64), font: &[u8], meta: &Metadata) -> Result<Vec<u8>> {
    use pdf_writer::{Content, Finish, Name, Pdf, Rect, Ref, TextStr};
    let mut options = svg2pdf::usvg::Options::default();
    let family = {
        let db = options.fontdb_mut();
        db.load_font_data(font.to_vec());
        let family = db.faces().next().and_then(|f| f.families.first()).map(|f| f.0.clone());
        if let Some(f) = &family {
            db.set_sans_serif_family(f.clone());
        }
        family
    };
    if let Some(f) = family {
        options.font_family = f;
    }
    let tree = svg2pdf::usvg::Tree::from_str(svg, &options).map_err(|e| anyhow!("PDF: reading the drawn SVG: {e}"))?;
    let (chunk, svg_ref) = svg2pdf::to_chunk(&tree, svg2pdf::ConversionOptions::default()).map_err(|e| anyhow!("PDF: converting: {e:?}"))?;
    // our five objects first, the converted drawing after them
    let (catalog, pages, page_ref, content_ref, info) = (Ref::new(1), Ref::new(2), Ref::new(3), Ref::new(4), Ref::new(5));
    let offset = 5;
    let chunk = chunk.renumber(|r| Ref::new(r.get() + offset));
    let svg_ref = Ref::new(svg_ref.get() + offset);
    let mut pdf = Pdf::new();
    pdf.catalog(catalog).pages(pages);
    pdf.pages(pages).kids([page_ref]).count(1);
    let mut p = pdf.page(page_ref);
    p.media_box(Rect::new(0.0, 0.0, page.0 as f32, page.1 as f32));
    p.parent(pages);
    p.contents(content_ref);
    p.resources().x_objects().pair(Name(b"F0"), svg_ref);
    p.finish();
    let mut content = Content::new();
    content.transform([page.0 as f32, 0.0, 0.0, page.1 as f32, 0.0, 0.0]).x_object(Name(b"F0"));
    pdf.stream(content_ref, &content.finish());
    let mut d = pdf.document_info(info);
    d.title(TextStr(&meta.title));
    d.subject(TextStr(&format!("{} of {}", meta.provenance.stage, meta.provenance.archive)));
    d.creator(TextStr(&Metadata::software()));
    d.producer(TextStr("svg2pdf"));
    d.pair(Name(b"Archive"), TextStr(&meta.provenance.archive));
    d.pair(Name(b"Stage"), TextStr(&meta.provenance.stage));
    d.finish();
    pdf.extend(&chunk);
    Ok(pdf.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_gets_print_size_and_provenance() {
        let meta = Metadata { title: "T <1>".into(), provenance: Provenance { archive: "/a/b.h5".into(), stage: "grid@v2".into() } };
        let svg = "<svg width=\"1000\" height=\"500\" viewBox=\"0 0 1000 500\" xmlns=\"http://www.w3.org/2000/svg\">\n<rect/></svg>";
        let out = svg_with_metadata(svg, (500.0, 250.0), &meta);
        assert!(out.starts_with("<svg width=\"500.00pt\" height=\"250.00pt\" viewBox=\"0 0 1000 500\""), "{out}");
        assert!(out.contains("<title>T &lt;1&gt;</title>") && out.contains("grid@v2") && out.contains("/a/b.h5"), "{out}");
        assert!(out.ends_with("<rect/></svg>"));
    }
}
