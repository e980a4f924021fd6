//! Hostile inputs end within milliseconds with an error naming the cause (issue 39): an element
//! of 300,000 attributes (the XML parser's duplicate check is quadratic in them), a FIFO with
//! no writer as the file, and a malformed file named in its error.

use articula_model::{read_limited, LoadOptions, Model, ModelError, MAX_XML_ATTRIBUTES};
use std::time::Instant;

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("articula-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn attribute_flood_is_refused_before_parsing() {
    let attrs: String = (0..300_000).map(|i| format!(" a{i}=\"1\"")).collect();
    let text = format!("<robot name=\"r\">\n<link name=\"a\"{attrs}/></robot>");
    assert!(text.len() > 3_000_000);
    let t = Instant::now();
    let e = Model::from_urdf_str(&text, &LoadOptions::default()).unwrap_err();
    assert!(t.elapsed().as_secs_f64() < 2.0, "{:?}", t.elapsed());
    assert_eq!(
        e,
        ModelError::TooManyAttributes {
            line: 2,
            column: 1,
            limit: MAX_XML_ATTRIBUTES
        }
    );
    // Up to the cap is fine; '=' inside quoted values does not count.
    let ok: String = (0..MAX_XML_ATTRIBUTES - 1)
        .map(|i| format!(" a{i}=\"x=y\""))
        .collect();
    let text = format!("<robot name=\"r\"><link name=\"a\"{ok}/></robot>");
    Model::from_urdf_str(&text, &LoadOptions::default()).unwrap();
}

#[test]
fn malformed_file_errors_name_the_file() {
    let path = scratch("broken.urdf");
    std::fs::write(&path, "<robot name=\"r\"><link name=\"a\"></robot>").unwrap();
    let e = Model::from_urdf_file(&path, &LoadOptions::default()).unwrap_err();
    let ModelError::InFile { path: p, source } = &e else {
        panic!("expected InFile, got {e:?}");
    };
    assert_eq!(p, &path.display().to_string());
    assert!(
        matches!(**source, ModelError::Xml { line: 1, .. }),
        "{source:?}"
    );
    assert!(
        e.to_string().starts_with(&path.display().to_string()),
        "{e}"
    );
}

#[cfg(unix)]
#[test]
fn fifo_is_refused_without_blocking() {
    let path = scratch("pipe.urdf");
    let _ = std::fs::remove_file(&path);
    let status = std::process::Command::new("mkfifo").arg(&path).status();
    if !status.is_ok_and(|s| s.success()) {
        eprintln!("no mkfifo here: skipped");
        return;
    }
    let t = Instant::now();
    let e = read_limited(&path, 1 << 20).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
    assert!(e.to_string().contains("FIFO"), "{e}");
    let e = Model::from_urdf_file(&path, &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("FIFO"), "{e}");
    assert!(t.elapsed().as_secs_f64() < 2.0);
    std::fs::remove_file(&path).unwrap();
}
