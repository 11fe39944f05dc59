//! WGSL sources, embedded at build time, and the textual `#include "file"` expansion the
//! passes use for shared code (`shaders/*.inc.wgsl`). `tests/shaders_naga.rs` runs the same
//! expansion on the files on disk before validating them with naga.

/// Every file under `shaders/`, by file name.
pub const FILES: &[(&str, &str)] = &[
    (
        "common.inc.wgsl",
        include_str!("../../shaders/common.inc.wgsl"),
    ),
    ("shadow.wgsl", include_str!("../../shaders/shadow.wgsl")),
    ("direct.wgsl", include_str!("../../shaders/direct.wgsl")),
    ("csl.inc.wgsl", include_str!("../../shaders/csl.inc.wgsl")),
    ("csl.wgsl", include_str!("../../shaders/csl.wgsl")),
    ("gbuffer.wgsl", include_str!("../../shaders/gbuffer.wgsl")),
    (
        "transport.wgsl",
        include_str!("../../shaders/transport.wgsl"),
    ),
    (
        "occlusion.inc.wgsl",
        include_str!("../../shaders/occlusion.inc.wgsl"),
    ),
];

/// Replaces each line `#include "name"` with the text `lookup(name)` returns, recursively
/// (depth-limited); an unknown name is an error.
pub fn expand_includes(
    src: &str,
    lookup: &dyn Fn(&str) -> Option<String>,
) -> Result<String, String> {
    fn go(
        src: &str,
        lookup: &dyn Fn(&str) -> Option<String>,
        depth: u32,
        out: &mut String,
    ) -> Result<(), String> {
        if depth > 8 {
            return Err("#include nested too deeply".into());
        }
        for line in src.lines() {
            let t = line.trim();
            if let Some(rest) = t.strip_prefix("#include") {
                let name = rest.trim().trim_matches('"');
                let text = lookup(name)
                    .ok_or_else(|| format!("#include {name:?}: no such shader file"))?;
                go(&text, lookup, depth + 1, out)?;
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
        Ok(())
    }
    let mut out = String::new();
    go(src, lookup, 0, &mut out)?;
    Ok(out)
}

/// The embedded shader `name` with its includes expanded.
pub fn source(name: &str) -> String {
    let lookup = |n: &str| {
        FILES
            .iter()
            .find(|(f, _)| *f == n)
            .map(|(_, s)| s.to_string())
    };
    let src = lookup(name).unwrap_or_else(|| panic!("no embedded shader {name}"));
    expand_includes(&src, &lookup).unwrap_or_else(|e| panic!("{name}: {e}"))
}
