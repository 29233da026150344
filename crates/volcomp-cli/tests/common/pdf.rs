//! The text of each page of a PDF as Chromium prints it (ISO 32000-1):
//! enough to check what a printed report says, not a general PDF reader.
//! Objects `N 0 obj … endobj`; content and CMap streams Flate-compressed
//! (§7.4.4); text shown with `Tj`/`TJ` as glyph codes of two bytes, which
//! each font's `/ToUnicode` CMap (§9.10.3: `bfchar`, `bfrange`) maps to
//! characters.

use std::collections::HashMap;
use std::io::Read;

fn find(hay: &[u8], needle: &[u8], from: usize) -> Option<usize> {
    hay.get(from..)?
        .windows(needle.len())
        .position(|w| w == needle)
        .map(|i| i + from)
}

/// Every `N 0 obj … endobj`, by number.
fn objects(pdf: &[u8]) -> HashMap<u32, &[u8]> {
    let mut out = HashMap::new();
    let mut at = 0;
    while let Some(i) = find(pdf, b" 0 obj", at) {
        let start = pdf[..i]
            .iter()
            .rposition(|c| !c.is_ascii_digit())
            .map_or(0, |k| k + 1);
        let Some(end) = find(pdf, b"endobj", i) else {
            break;
        };
        if let Ok(n) = std::str::from_utf8(&pdf[start..i]).unwrap_or("").parse() {
            out.insert(n, &pdf[i + 6..end]);
        }
        at = end + 6;
    }
    out
}

/// The decoded stream of an object, if it has one.
fn stream(body: &[u8]) -> Option<Vec<u8>> {
    let s = find(body, b"stream", 0)?;
    let mut s = s + 6;
    while matches!(body.get(s), Some(b'\r' | b'\n')) {
        s += 1;
    }
    let e = find(body, b"endstream", s)?;
    let data = &body[s..e];
    if find(&body[..s], b"/FlateDecode", 0).is_some() {
        let mut out = Vec::new();
        flate2::read::ZlibDecoder::new(data)
            .read_to_end(&mut out)
            .ok()?;
        Some(out)
    } else {
        Some(data.to_vec())
    }
}

/// `<hex>` groups of `text`, as numbers.
fn hex_groups(text: &str) -> Vec<String> {
    text.split('<')
        .skip(1)
        .filter_map(|t| t.split('>').next())
        .map(str::to_string)
        .collect()
}

fn utf16(hex: &str) -> String {
    let units: Vec<u16> = (0..hex.len() / 4)
        .filter_map(|k| u16::from_str_radix(&hex[4 * k..4 * k + 4], 16).ok())
        .collect();
    String::from_utf16_lossy(&units)
}

/// A `/ToUnicode` CMap: glyph code → text.
fn cmap(text: &str) -> HashMap<u32, String> {
    let mut map = HashMap::new();
    let blocks = |open: &str, close: &str| -> Vec<String> {
        text.split(open)
            .skip(1)
            .filter_map(|b| b.split(close).next())
            .map(str::to_string)
            .collect()
    };
    for b in blocks("beginbfchar", "endbfchar") {
        for pair in hex_groups(&b).chunks(2) {
            if let [code, to] = pair {
                if let Ok(c) = u32::from_str_radix(code, 16) {
                    map.insert(c, utf16(to));
                }
            }
        }
    }
    for b in blocks("beginbfrange", "endbfrange") {
        for triple in hex_groups(&b).chunks(3) {
            if let [lo, hi, to] = triple {
                let (Ok(lo), Ok(hi), Ok(to)) = (
                    u32::from_str_radix(lo, 16),
                    u32::from_str_radix(hi, 16),
                    u32::from_str_radix(to, 16),
                ) else {
                    continue;
                };
                for c in lo..=hi {
                    let ch = char::from_u32(to + c - lo).unwrap_or('?');
                    map.insert(c, ch.to_string());
                }
            }
        }
    }
    map
}

/// The number after `key` in `body` as an object reference (`key N 0 R`).
fn reference(body: &str, key: &str) -> Option<u32> {
    let at = body.find(key)? + key.len();
    body[at..].split_whitespace().next()?.parse().ok()
}

/// The text of every page, in the order of the page objects.
pub fn page_texts(pdf: &[u8]) -> Vec<String> {
    let objs = objects(pdf);
    let text_of =
        |n: u32| String::from_utf8_lossy(objs.get(&n).copied().unwrap_or(b"")).into_owned();
    let mut numbers: Vec<u32> = objs.keys().copied().collect();
    numbers.sort_unstable();
    let mut pages = Vec::new();
    for n in numbers {
        let body = text_of(n).replace("/Type/Page", "/Type /Page");
        let Some(i) = body.find("/Type /Page") else {
            continue;
        };
        if body[i + 11..].starts_with('s') {
            continue;
        }
        // The page's fonts: resource name → its ToUnicode map.
        let mut resources = body.clone();
        if !resources.contains("/Font") {
            if let Some(r) = reference(&body, "/Resources") {
                resources = text_of(r);
            }
        }
        let mut fonts: HashMap<String, HashMap<u32, String>> = HashMap::new();
        if let Some(f) = resources.find("/Font") {
            let dict = &resources[f + 5..];
            let dict = dict[..dict.find(">>").unwrap_or(dict.len())].replace("<<", " ");
            let mut words = dict.split_whitespace().peekable();
            while let Some(w) = words.next() {
                if let (Some(name), Some(obj)) = (w.strip_prefix('/'), words.peek()) {
                    let font_obj = obj.parse::<u32>().ok();
                    if let Some(tu) = font_obj.and_then(|o| reference(&text_of(o), "/ToUnicode")) {
                        let map = objs
                            .get(&tu)
                            .and_then(|b| stream(b))
                            .map_or_else(HashMap::new, |s| cmap(&String::from_utf8_lossy(&s)));
                        fonts.insert(name.to_string(), map);
                    }
                }
            }
        }
        let content = reference(&body, "/Contents")
            .and_then(|c| objs.get(&c))
            .and_then(|b| stream(b))
            .unwrap_or_default();
        pages.push(show(&String::from_utf8_lossy(&content), &fonts));
    }
    pages
}

/// The text a content stream shows with its fonts.
fn show(content: &str, fonts: &HashMap<String, HashMap<u32, String>>) -> String {
    let empty = HashMap::new();
    let mut font = &empty;
    let mut out = String::new();
    let mut rest = content;
    while !rest.is_empty() {
        let Some(k) = rest.find(['/', '<', '[']) else {
            break;
        };
        rest = &rest[k..];
        if let Some(r) = rest.strip_prefix('/') {
            let end = r.find(|c: char| c.is_whitespace()).unwrap_or(r.len());
            let name = &r[..end];
            let after = r[end..].trim_start();
            // `/F4 12 Tf`: a number then Tf.
            let mut parts = after.split_whitespace();
            if parts.next().is_some_and(|n| n.parse::<f64>().is_ok()) && parts.next() == Some("Tf")
            {
                font = fonts.get(name).unwrap_or(&empty);
            }
            rest = &r[end..];
            continue;
        }
        let close = if rest.starts_with('[') { ']' } else { '>' };
        let end = rest.find(close).map_or(rest.len(), |e| e + 1);
        for hex in hex_groups(&rest[..end]) {
            for k in 0..hex.len() / 4 {
                if let Ok(code) = u32::from_str_radix(&hex[4 * k..4 * k + 4], 16) {
                    out.push_str(font.get(&code).map_or("?", String::as_str));
                }
            }
        }
        rest = &rest[end..];
    }
    out
}
