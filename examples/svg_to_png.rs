//! Renders report figures (SVG) to PNG for looking at them, with the bundled font:
//! `cargo run --release --example svg_to_png -- reports/model/lab_measured.svg /tmp/lab.png`.
//! A development tool (issue 16: check each figure by eye); the reports stay SVG.

use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 || args.len() % 2 != 0 {
        return Err("usage: svg_to_png IN.svg OUT.png [IN2.svg OUT2.png …]".into());
    }
    let mut options = resvg::usvg::Options::default();
    options.fontdb_mut().load_font_data(std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/fonts/DejaVuSans.ttf"),
    )?);
    options.font_family = "DejaVu Sans".into();
    for pair in args.chunks(2) {
        let svg = std::fs::read(&pair[0])?;
        let tree = resvg::usvg::Tree::from_data(&svg, &options)?;
        let size = tree.size().to_int_size();
        let mut pixmap =
            resvg::tiny_skia::Pixmap::new(size.width(), size.height()).ok_or("an empty figure")?;
        pixmap.fill(resvg::tiny_skia::Color::WHITE);
        resvg::render(
            &tree,
            resvg::tiny_skia::Transform::default(),
            &mut pixmap.as_mut(),
        );
        pixmap.save_png(&pair[1])?;
        eprintln!("{} → {}", pair[0], pair[1]);
    }
    Ok(())
}
