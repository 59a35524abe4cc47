//! The written calib read back, by panoconv (`Calib::output_camera`, `labels-to-pixels`) and by
//! the Python function of docs/formats.md.

use super::boxes::parse_label;
use super::*;
use crate::opencv_ref;
use nalgebra::Vector3;
use panoconv::camera::CameraModel;
use panoconv::kitti::Cam;
use panoconv::tools::synth::frames;

/// Bearings all over the sphere (θ up to 180°), in rect.
fn sphere_bearings() -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for i in 0..=90 {
        let theta = std::f64::consts::PI * i as f64 / 90.0;
        for j in 0..48 {
            let phi = std::f64::consts::TAU * j as f64 / 48.0;
            out.push(Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ));
        }
    }
    out
}

/// The Python function between the markers of docs/formats.md.
fn docs_python() -> String {
    let doc = read_text(&Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/formats.md"));
    let begin = doc
        .find("<!-- fisheye-python-begin -->")
        .expect("docs/formats.md: no fisheye-python-begin marker");
    let end = doc
        .find("<!-- fisheye-python-end -->")
        .expect("docs/formats.md: no fisheye-python-end marker");
    let block = &doc[begin..end];
    let code = block
        .split_once("```python\n")
        .and_then(|(_, rest)| rest.split_once("```"))
        .expect("a ```python block between the markers")
        .0;
    code.to_owned()
}

/// Runs the docs' function on the box centres (location − half the height) of each frame's
/// `labels` with its `calib`, in one interpreter (its start, numpy's import, costs more than
/// the projections): per frame, one entry per label, (u, v) or None.
fn python_box_centres(frames: &[(PathBuf, Vec<String>)]) -> Vec<Vec<Option<(f64, f64)>>> {
    let driver = r#"
import sys, json
for path, centres in json.load(open(sys.argv[1])):
    calib = read_calib(path)
    for x, y, z, h in centres:
        p = project_fisheye(calib, [x, y - h / 2, z])
        print("None" if p is None else "%r %r" % (float(p[0]), float(p[1])))
    print("end of frame")
"#;
    let request: Vec<(&str, Vec<[f64; 4]>)> = frames
        .iter()
        .map(|(calib, labels)| {
            let centres = labels
                .iter()
                .map(|l| {
                    let t: Vec<f64> = tokens(l)[8..14]
                        .iter()
                        .map(|v| v.parse().unwrap())
                        .collect();
                    [t[3], t[4], t[5], t[0]]
                })
                .collect();
            (calib.to_str().unwrap(), centres)
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let req = dir.path().join("centres.json");
    std::fs::write(&req, serde_json::to_string(&request).unwrap()).unwrap();
    let script = format!("{}\n{driver}", docs_python());
    let stdout = opencv_ref::run_python(&script, &[req.to_str().unwrap()]);
    let mut out = vec![Vec::new()];
    for l in stdout.lines() {
        if l == "end of frame" {
            out.push(Vec::new());
            continue;
        }
        out.last_mut().unwrap().push((l != "None").then(|| {
            let v: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            (v[0], v[1])
        }));
    }
    out.pop();
    assert_eq!(out.len(), frames.len(), "python: {stdout}");
    out
}

#[test]
fn the_written_calib_projects_like_the_camera_that_wrote_it_in_panoconv_and_in_python() {
    let dir = tempfile::tempdir().unwrap();
    let mut report = Vec::new();
    for model in MODELS {
        // Yawed 70° right and pitched: objects on the left lie beyond 90° of the axis.
        let json = camera_json(model, fov_of(model), -10.0, (1000, 700), (499.5, 349.5))
            .replace("\"yaw_deg\": 0", "\"yaw_deg\": 70")
            .replace(&format!("{CENTRE_SCALE}"), "300")
            .replace(&format!("{}", 2.2 * CENTRE_SCALE), "660")
            .replace(&format!("{}", 0.8 * CENTRE_SCALE), "240");
        let cam_path = write_camera(dir.path(), &format!("{model}.json"), &json);
        let out = dir.path().join(model);
        convert(&cam_path, synth_source(), &out, &["--split", "training"]);
        let pixels = dir.path().join(format!("{model}-pixels"));
        assert_success(&panoconv([
            "labels-to-pixels".as_ref(),
            "--input".as_ref(),
            out.as_os_str(),
            "--output".as_ref(),
            pixels.as_os_str(),
        ]));
        let writer = fisheye_camera(&cam_path);
        let (mut worst_calib, mut worst_py_lib, mut worst_py_file) = (0.0f64, 0.0f64, 0.0f64);
        let mut objects = 0;
        // (b)'s objects: every label but DontCare, each frame's through the Python at once.
        let training: Vec<&str> = SYNTH_FRAMES
            .iter()
            .filter(|(s, _)| *s == "training")
            .map(|(_, id)| *id)
            .collect();
        let calib_of = |id: &str| out.join(format!("training/calib/{id}.txt"));
        let labels_of = |id: &str| -> Vec<String> {
            label_lines(&read_text(&out.join(format!("training/label_2/{id}.txt"))))
                .into_iter()
                .filter(|l| !l.starts_with("DontCare"))
                .map(str::to_owned)
                .collect()
        };
        let python: Vec<(PathBuf, Vec<String>)> = training
            .iter()
            .map(|id| (calib_of(id), labels_of(id)))
            .collect();
        let python = python_box_centres(&python);
        for (id, py) in training.iter().zip(&python) {
            let calib_path = calib_of(id);
            let calib = panoconv::kitti::Calib::read(&calib_path).unwrap();
            let (read, centre) = calib.output_camera(Cam::C2, writer.size()).unwrap();
            let truth = frames()
                .into_iter()
                .find(|f| f.id == *id)
                .unwrap()
                .calib
                .centre();
            assert!(
                (centre - truth).norm() < 1e-9,
                "{model} {id}: C2 {centre:?}"
            );
            // (a) Calib::output_camera projects like the writer, and refuses the same bearings.
            for d in sphere_bearings() {
                match (writer.project(&d), read.project(&d)) {
                    (Ok(a), Ok(b)) => worst_calib = worst_calib.max((a - b).norm()),
                    (Err(_), Err(_)) => {}
                    (a, b) => panic!("{model}: {d:?}: writer {a:?}, read back {b:?}"),
                }
            }
            // (b) The docs' Python function against panoconv's projection and its file.
            let labels = labels_of(id);
            let file: Vec<Vec<f64>> = read_text(&pixels.join(format!("{id}.txt")))
                .lines()
                .filter(|l| !l.starts_with('#'))
                .map(|l| tokens(l)[1..3].iter().map(|v| v.parse().unwrap()).collect())
                .collect();
            let mut in_file = file.iter();
            for (line, p) in labels.iter().zip(py) {
                let label = parse_label(line);
                let lib =
                    panoconv::tools::unproject::label_to_pixel(&label, read.as_ref(), &centre);
                match (p, lib) {
                    (Some((u, v)), Some(o)) => {
                        worst_py_lib = worst_py_lib.max((u - o.u).hypot(v - o.v));
                        let f = in_file.next().expect("labels-to-pixels wrote the object");
                        worst_py_file = worst_py_file.max((u - f[0]).abs().max((v - f[1]).abs()));
                        objects += 1;
                    }
                    (None, None) => {}
                    (p, o) => panic!("{model} {id}: {line}: python {p:?}, panoconv {o:?}"),
                }
            }
            assert!(
                in_file.next().is_none(),
                "{model} {id}: more objects in the file"
            );
        }
        report.push(format!(
            "{model}: read back {worst_calib:.1e} px, python vs panoconv {worst_py_lib:.1e} px, \
             vs labels-to-pixels {worst_py_file:.1e} px over {objects} objects"
        ));
        assert!(
            worst_calib <= 1e-9,
            "{model}: read back off by {worst_calib} px"
        );
        assert!(
            worst_py_lib <= 1e-6,
            "{model}: python off by {worst_py_lib} px"
        );
        // labels-to-pixels writes 4 decimals: half a unit of the last one.
        assert!(
            worst_py_file <= 5e-5 + 1e-6,
            "{model}: file off by {worst_py_file} px"
        );
        assert!(objects >= 5, "{model}: only {objects} objects compared");
        assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
    }
    eprintln!("{}", report.join("\n"));
}
