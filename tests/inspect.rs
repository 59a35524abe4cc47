//! `panoconv inspect`: the facts of ../shared/kitti against counts made independently here by
//! plain string splitting, problems reported as file:line: field, exit codes, stable JSON.

use crate::common::*;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn inspect(args: &[&std::ffi::OsStr]) -> Run {
    let mut all = vec![std::ffi::OsStr::new("inspect")];
    all.extend_from_slice(args);
    panoconv(all)
}

fn json(run: &Run) -> serde_json::Value {
    serde_json::from_str(&run.stdout).unwrap_or_else(|e| panic!("{e}: {}", run.stdout))
}

fn files(dir: &Path, ext: &str) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    v.retain(|p: &std::path::PathBuf| p.extension().is_some_and(|e| e == ext));
    v.sort();
    v
}

/// Width and height straight from the IHDR chunk.
fn ihdr(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
    assert_eq!(&b[12..16], b"IHDR");
    (be(16), be(20))
}

#[test]
fn reports_the_shared_kitti_facts() {
    let root = real_kitti();
    // expected, by simple string splitting
    let mut frames = 0;
    let mut classes: BTreeMap<String, u64> = BTreeMap::new();
    let mut sizes: BTreeMap<(u32, u32), u64> = BTreeMap::new();
    let mut p2s: BTreeMap<String, u64> = BTreeMap::new();
    let mut small = 0;
    for split in ["training", "testing"] {
        for img in files(&root.join(split).join("image_2"), "png") {
            frames += 1;
            *sizes.entry(ihdr(&img)).or_default() += 1;
            let id = img.file_stem().unwrap().to_str().unwrap();
            let calib = read_text(&root.join(split).join("calib").join(format!("{id}.txt")));
            let p2 = calib.lines().find(|l| l.starts_with("P2:")).unwrap();
            *p2s.entry(p2.trim().to_owned()).or_default() += 1;
        }
        for lab in files(&root.join(split).join("label_2"), "txt") {
            for line in read_text(&lab).lines().filter(|l| !l.trim().is_empty()) {
                let t: Vec<&str> = line.split_whitespace().collect();
                *classes.entry(t[0].to_owned()).or_default() += 1;
                let h = t[7].parse::<f64>().unwrap() - t[5].parse::<f64>().unwrap();
                if t[0] != "DontCare" && h < 25.0 {
                    small += 1;
                }
            }
        }
    }
    assert_eq!(frames, 7);
    assert_eq!(sizes.len(), 2, "two image sizes in the sample");
    assert_eq!(p2s.len(), 2, "two calibrations in the sample");

    let run = inspect(&[root.as_os_str(), "--json".as_ref()]);
    assert_eq!(
        run.code, 0,
        "the sample is clean: {}{}",
        run.stdout, run.stderr
    );
    let j = json(&run);
    assert_eq!(j["frames"], frames);
    assert_eq!(j["splits"][0]["name"], "training");
    assert_eq!(j["splits"][0]["frames"], 6);
    assert_eq!(j["splits"][0]["labelled"], true);
    assert_eq!(j["splits"][1]["name"], "testing");
    assert_eq!(j["splits"][1]["frames"], 1);
    let got: BTreeMap<String, u64> = j["classes"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
        .collect();
    assert_eq!(got, classes);
    let got: BTreeMap<(u32, u32), u64> = j["image_sizes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                (
                    s["width"].as_u64().unwrap() as u32,
                    s["height"].as_u64().unwrap() as u32,
                ),
                s["count"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(got, sizes);
    assert_eq!(got[&(1224, 370)], 1);
    let cal = j["calibrations"].as_array().unwrap();
    assert_eq!(cal.len(), p2s.len());
    let mut counts: Vec<u64> = cal.iter().map(|c| c["count"].as_u64().unwrap()).collect();
    let mut want: Vec<u64> = p2s.values().copied().collect();
    counts.sort();
    want.sort();
    assert_eq!(counts, want);
    // the odd one out is frame 000000 (1224x370, other intrinsics)
    let odd = cal.iter().find(|c| c["count"] == 1).unwrap();
    assert_eq!(odd["first_frame"], "training/000000");
    assert!((odd["fu"].as_f64().unwrap() - 707.0493).abs() < 1e-9);
    let c2 = odd["c2"].as_array().unwrap();
    assert!((c2[0].as_f64().unwrap() + 0.0605).abs() < 1e-3, "{c2:?}");
    assert_eq!(j["small_objects"]["threshold_px"], 25.0);
    assert_eq!(j["small_objects"]["count"], small);
    assert_eq!(j["projections"]["kitti"], 7);
    assert_eq!(j["problems"].as_array().unwrap().len(), 0);

    // stable key order: as declared, whatever the data
    let keys = [
        "\"dataset\"",
        "\"frames\"",
        "\"splits\"",
        "\"classes\"",
        "\"image_sizes\"",
        "\"calibrations\"",
        "\"projections\"",
        "\"small_objects\"",
        "\"problems\"",
    ];
    let pos: Vec<usize> = keys
        .iter()
        .map(|k| run.stdout.find(&format!("\n  {k}")).unwrap())
        .collect();
    assert!(pos.windows(2).all(|w| w[0] < w[1]), "{pos:?}");
    // deterministic
    assert_eq!(
        inspect(&[root.as_os_str(), "--json".as_ref()]).stdout,
        run.stdout
    );

    // the text report says the same
    let run = inspect(&[root.as_os_str()]);
    assert_eq!(run.code, 0);
    let t = &run.stdout;
    assert!(t.contains("frames: 7 (training 6, testing 1)"), "{t}");
    assert!(t.contains("image sizes: 2 distinct"), "{t}");
    assert!(t.contains("1224x370"), "{t}");
    assert!(t.contains("calibrations: 2 distinct"), "{t}");
    for (class, n) in &classes {
        assert!(
            t.lines().any(|l| {
                let w: Vec<&str> = l.split_whitespace().collect();
                w == [class.as_str(), &n.to_string()]
            }),
            "{class} {n} in\n{t}"
        );
    }
    assert!(
        t.contains(&format!("objects under 25 px tall: {small}")),
        "{t}"
    );
    assert!(t.contains("problems: none"), "{t}");

    // one split only
    let run = inspect(&[root.as_os_str(), "--split".as_ref(), "testing".as_ref()]);
    assert_eq!(run.code, 0);
    assert!(
        run.stdout.contains("frames: 1 (testing 1)"),
        "{}",
        run.stdout
    );
}

#[test]
fn reports_missing_and_malformed_files_with_exit_1() {
    let s = Scratch::synth();
    let lab = s.input_file("training/label_2/000001.txt");
    let text = read_text(&lab);
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let mut t: Vec<&str> = lines[1].split_whitespace().collect();
    t[12] = "abc";
    lines[1] = t.join(" ");
    lines.push("Car 0 0".into());
    write_text(&lab, &(lines.join("\n") + "\n"));
    // a frame without calib, a label without image, a calib with a bad P2
    std::fs::remove_file(s.input_file("training/calib/000002.txt")).unwrap();
    write_text(&s.input_file("training/label_2/000009.txt"), "");
    let cal = s.input_file("testing/calib/000003.txt");
    let c = read_text(&cal).replace("P2: 7.215377000000e+02", "P2: x");
    write_text(&cal, &c);

    let run = inspect(&[s.input.as_os_str()]);
    assert_eq!(run.code, 1, "{}{}", run.stdout, run.stderr);
    let out = &run.stdout;
    for want in [
        "training/label_2/000001.txt:2: location.y: \"abc\" is not a number",
        &format!(
            "training/label_2/000001.txt:{}: fields: expected 15 fields (16 with score), found 3",
            lines.len()
        ),
        "training/calib/000002.txt: missing (the frame has training/image_2/000002.png)",
        "training/label_2/000009.txt: no image training/image_2/000009.png for it",
        "testing/calib/000003.txt:3: P2[0]: \"x\" is not a number",
        "problems: 5",
    ] {
        assert!(out.contains(want), "{want:?} not in\n{out}");
    }
    // the rest of the report is still there
    assert!(out.contains("frames: 4 (training 3, testing 1)"), "{out}");

    let run = inspect(&[s.input.as_os_str(), "--json".as_ref()]);
    assert_eq!(run.code, 1);
    let j = json(&run);
    let problems = j["problems"].as_array().unwrap();
    assert_eq!(problems.len(), 5);
    let first = problems
        .iter()
        .find(|p| p["field"] == "location.y")
        .unwrap();
    assert_eq!(first["file"], "training/label_2/000001.txt");
    assert_eq!(first["line"], 2);
    let keys: BTreeSet<&str> = first
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(keys, BTreeSet::from(["file", "line", "field", "message"]));
}

#[test]
fn set_up_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let run = inspect(&[dir.path().join("nope").as_os_str()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("is not a directory"), "{}", run.stderr);
    let run = inspect(&[dir.path().as_os_str()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stdout.is_empty());
    let run = inspect(&[real_kitti().as_os_str(), "--split".as_ref(), "val".as_ref()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
}

#[test]
fn inspects_a_converted_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    assert_success(&kitti("cylindrical", &real_kitti(), &out, &["--quiet"]));
    let run = inspect(&[out.as_os_str(), "--json".as_ref()]);
    assert_eq!(run.code, 0, "{}", run.stdout);
    let j = json(&run);
    assert_eq!(j["frames"], 7);
    assert_eq!(j["projections"]["cylindrical"], 7);
    // P2 stays the source camera for cylindrical outputs: still two calibrations
    assert_eq!(j["calibrations"].as_array().unwrap().len(), 2);
}

/// Cuts `path` to `len` bytes.
fn cut(path: &Path, len: u64) {
    let f = std::fs::OpenOptions::new().write(true).open(path).unwrap();
    f.set_len(len).unwrap();
}

#[test]
fn reports_truncated_images_and_missing_or_broken_scans() {
    let s = Scratch::synth();
    // a clean copy first: the checks below find nothing on it
    let run = inspect(&[s.input.as_os_str()]);
    assert_eq!(run.code, 0, "{}{}", run.stdout, run.stderr);
    assert!(run.stdout.contains("problems: none"), "{}", run.stdout);

    // image_2 cut inside a chunk (its header, and so its size, still reads)
    let img = s.input_file("training/image_2/000001.png");
    let len = std::fs::metadata(&img).unwrap().len();
    cut(&img, len / 2);
    // image_3 cut exactly before its IEND chunk (12 bytes: length, type, CRC)
    let right = s.input_file("training/image_3/000002.png");
    let right_len = std::fs::metadata(&right).unwrap().len();
    cut(&right, right_len - 12);
    // one training scan missing while the others are there; one scan 5 bytes too long
    std::fs::remove_file(s.input_file("training/velodyne/000002.bin")).unwrap();
    let bin = s.input_file("training/velodyne/000000.bin");
    let bin_len = std::fs::metadata(&bin).unwrap().len();
    let mut bytes = std::fs::read(&bin).unwrap();
    bytes.extend_from_slice(&[0; 5]);
    std::fs::write(&bin, &bytes).unwrap();
    // a split without any scan is not a problem: testing has only this one
    std::fs::remove_file(s.input_file("testing/velodyne/000003.bin")).unwrap();

    let run = inspect(&[s.input.as_os_str()]);
    assert_eq!(run.code, 1, "{}{}", run.stdout, run.stderr);
    let out = &run.stdout;
    for want in [
        "training/image_2/000001.png: truncated: the IDAT chunk at byte ".to_owned(),
        format!("but the file ends at byte {}", len / 2),
        format!(
            "training/image_3/000002.png: truncated: {} bytes, ending after the IDAT chunk at byte {} without the IEND chunk",
            right_len - 12,
            right_len - 12
        ),
        "training/velodyne/000002.bin: missing (2 of the split's 3 frames have a velodyne file)"
            .to_owned(),
        format!(
            "training/velodyne/000000.bin: {} bytes is not a whole number of 16-byte points",
            bin_len + 5
        ),
        "problems: 4".to_owned(),
    ] {
        assert!(out.contains(&want), "{want:?} not in\n{out}");
    }
    assert!(!out.contains("testing/velodyne"), "{out}");

    let j = json(&inspect(&[s.input.as_os_str(), "--json".as_ref()]));
    let problems = j["problems"].as_array().unwrap();
    let files: Vec<&str> = problems
        .iter()
        .map(|p| p["file"].as_str().unwrap())
        .collect();
    assert_eq!(
        files,
        [
            "training/image_2/000001.png",
            "training/image_3/000002.png",
            "training/velodyne/000000.bin",
            "training/velodyne/000002.bin",
        ]
    );
    // the truncated image_2 is not counted among the sizes: 3 whole images of 4 frames
    let sized: u64 = j["image_sizes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|z| z["count"].as_u64().unwrap())
        .sum();
    assert_eq!(sized, 3);
}
