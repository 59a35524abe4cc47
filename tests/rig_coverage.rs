//! What the summary says of the part of a rig output no camera covers. A whole sphere's rows
//! above and below the cameras are what was asked for (`--full-360`, or `--pano-width` alone,
//! which keeps the whole sphere): a note that counts those rows and gives the `--crop` that
//! keeps the band, not a warning that reads as a user error; the same for a fisheye target's
//! field beyond the rig. Pixels without a camera among the rows the cameras see (gaps between
//! the chosen cameras) stay a warning. Through the binary on the nuScenes fixture.

use crate::common::*;
use std::path::Path;

fn nuscenes(out: &Path, extra: &[&str]) -> Run {
    let input = repo().join("fixtures/nuscenes");
    let mut args = vec!["nuscenes", "--input", input.to_str().unwrap()];
    args.extend(["--version", "v1.0-mini", "--output", out.to_str().unwrap()]);
    args.extend(extra);
    let run = panoconv(&args);
    assert_success(&run);
    run
}

/// The first frame's source map: its height and the first and last rows with a camera.
fn covered_rows(out: &Path) -> (u32, u32, u32) {
    let png = read_png(&out.join("training/source_2/000000.png"));
    let w = png.width as usize;
    let seen: Vec<u32> = (0..png.height)
        .filter(|&y| {
            let row = &png.data[y as usize * w..(y as usize + 1) * w];
            row.iter().any(|&v| v != 255)
        })
        .collect();
    (png.height, seen[0], *seen.last().unwrap())
}

/// The `--crop X,Y,W,H` the line names.
fn crop_named(line: &str) -> String {
    let at = line.find("--crop ").expect("a crop named") + "--crop ".len();
    let window = &line[at..];
    window[..window.find([' ', ';']).unwrap_or(window.len())].to_owned()
}

#[test]
fn a_pano_width_alone_says_it_is_the_sphere_and_names_the_crop_of_the_band() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("width");
    let run = nuscenes(&out, &["--to", "equirect", "--pano-width", "1024"]);
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    let (h, first, last) = covered_rows(&out);
    let poles = h - (last - first + 1);
    assert!(poles * 2 > h, "most rows are the poles: {poles} of {h}");
    let line = (run.stderr.lines())
        .find(|l| l.starts_with("panoconv: note: "))
        .unwrap_or_else(|| panic!("no note: {}", run.stderr));
    for said in [
        "--pano-width without --full-360 or --size writes the whole sphere",
        &format!("{poles} of the {h} rows of "),
        "are beyond every camera (source_2 = 255)",
        "leave out --pano-width (2048 px for 360°)",
    ] {
        assert!(line.contains(said), "{said:?} not in {line}");
    }
    // the crop it names is the band: every row of it has a camera
    let crop = crop_named(line);
    assert_eq!(crop, format!("0,{first},1024,{}", last - first + 1));
    let cropped = tmp.path().join("cropped");
    let run = nuscenes(
        &cropped,
        &["--to", "equirect", "--pano-width", "1024", "--crop", &crop],
    );
    assert!(!run.stderr.contains("note:"), "{}", run.stderr);
    let (h, first, last) = covered_rows(&cropped);
    assert_eq!(
        (first, last),
        (0, h - 1),
        "the band, no row without a camera"
    );
}

#[test]
fn full_360_and_a_fisheye_target_get_a_note_and_gaps_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("full");
    let run = nuscenes(&out, &["--to", "equirect", "--full-360"]);
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    let (h, first, last) = covered_rows(&out);
    let said = format!(
        "{} of the {h} rows of {}",
        h - (last - first + 1),
        out.join("training/source_2/000000.png").display()
    );
    assert!(run.stderr.contains(&said), "{said:?} not in {}", run.stderr);
    assert!(run.stderr.contains("as --full-360 asks"), "{}", run.stderr);

    let out = tmp.path().join("fisheye");
    let camera = repo().join("fixtures/cameras/front.json");
    let fisheye = ["--to", "fisheye", "--camera", camera.to_str().unwrap()];
    let run = nuscenes(&out, &fisheye);
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    assert!(
        run.stderr
            .contains("the fisheye's field reaches past the rig's cameras"),
        "{}",
        run.stderr
    );

    // two opposite cameras leave most of the rows they see without a camera: a warning
    let out = tmp.path().join("gaps");
    let two = ["--to", "equirect", "--cameras", "CAM_FRONT,CAM_BACK"];
    let run = nuscenes(&out, &two);
    assert!(
        run.stderr.contains("that the cameras see has no camera")
            && run
                .stderr
                .contains("the chosen cameras leave gaps between them"),
        "{}",
        run.stderr
    );
}
