//! Fonts bundled with the reports.
//!
//! Figures draw text with DejaVu Sans, which has no Japanese glyphs: the Osafune experiments
//! quote the paper's joint names (左膝X, 肩Y, …), which plain Chromium and plotters would draw
//! as empty boxes. A subset of Noto Sans CJK JP (SIL OFL 1.1; `assets/subset_cjk_font.sh`
//! rebuilds it, `assets/NotoSansCJKjp-subset-LICENSE.txt` is its licence) covers ASCII, kana,
//! the report symbols and the CJK characters of the experiments plus a joint/gait vocabulary.
//! Pages and figures use it only where their text needs it, so every other page and figure
//! stays byte-identical.

use base64::Engine;

/// Noto Sans CJK JP Regular, subset (OpenType/CFF).
pub static CJK_FONT: &[u8] = include_bytes!("../assets/NotoSansCJKjp-subset.otf");

/// The family name pages and figures register the subset under.
pub const CJK_FAMILY: &str = "motionlab CJK";

/// Whether `c` is a CJK character (radicals, kana, ideographs, full-width forms) — none of
/// which DejaVu Sans draws.
pub fn is_cjk(c: char) -> bool {
    matches!(c as u32, 0x2E80..=0x9FFF | 0xF900..=0xFAFF | 0xFE30..=0xFE4F | 0xFF00..=0xFFEF)
}

/// Whether a text needs the CJK font.
pub fn needs_cjk(text: &str) -> bool {
    text.chars().any(is_cjk)
}

/// A `<style>` element declaring the embedded CJK font for CJK code points and appending it to
/// the page's font stack.
pub fn css_font_face() -> String {
    let data = base64::engine::general_purpose::STANDARD.encode(CJK_FONT);
    format!(
        "<style>@font-face {{ font-family: \"{CJK_FAMILY}\"; src: url(data:font/otf;base64,{data}) format(\"opentype\"); \
         unicode-range: U+2E80-9FFF, U+F900-FAFF, U+FE30-FE4F, U+FF00-FFEF; }}\n\
         body, button, select, input, canvas {{ font-family: \"DejaVu Sans\", Helvetica, Arial, \"{CJK_FAMILY}\", sans-serif; }}</style>\n"
    )
}

/// Inserts [`css_font_face`] before `</head>` when the page has CJK text; returns the page
/// unchanged otherwise.
pub fn with_cjk_font(page: String) -> String {
    match page.find("</head>") {
        Some(at) if needs_cjk(&page) => {
            let mut out = String::with_capacity(page.len() + CJK_FONT.len() * 4 / 3 + 400);
            out.push_str(&page[..at]);
            out.push_str(&css_font_face());
            out.push_str(&page[at..]);
            out
        }
        _ => page,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_subset_has_a_glyph_for_every_cjk_character_of_the_experiments() {
        let face = ab_glyph::FontRef::try_from_slice(CJK_FONT).unwrap();
        use ab_glyph::Font;
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../experiments");
        let mut seen = 0;
        for entry in std::fs::read_dir(dir).unwrap() {
            let text = std::fs::read_to_string(entry.unwrap().path()).unwrap_or_default();
            for c in text.chars().filter(|c| is_cjk(*c)) {
                assert_ne!(face.glyph_id(c).0, 0, "no glyph for {c:?}");
                seen += 1;
            }
        }
        assert!(seen > 0, "the experiments quote Japanese joint names");
        for c in "左膝X (left knee X) → 0.5 °".chars() {
            assert_ne!(face.glyph_id(c).0, 0, "no glyph for {c:?}");
        }
    }

    #[test]
    fn pages_get_the_font_only_when_they_need_it() {
        let plain = "<html><head></head><body>knee</body></html>".to_string();
        assert_eq!(with_cjk_font(plain.clone()), plain);
        let jp = with_cjk_font("<html><head></head><body>左膝X</body></html>".into());
        assert!(jp.contains("@font-face") && jp.find("@font-face") < jp.find("</head>"));
        assert!(!needs_cjk("–—→°²") && needs_cjk("肩Y"));
    }
}
