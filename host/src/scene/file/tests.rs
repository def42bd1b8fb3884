//! Parsing a small scene file, and errors that name the line and the field.

use std::path::PathBuf;

use gridrt_shared::scene::{ObjectKind, PrimKind, ReflectMode, TextureKind};

use super::*;

fn no_mesh(_: &Path) -> Result<Mesh, SceneLoadError> {
    Err(SceneLoadError::UnsupportedFormat { path: PathBuf::from("x") })
}

fn err(text: &str) -> String {
    parse(Path::new("s.toml"), text, &no_mesh).unwrap_err().to_string()
}

const OK: &str = r#"
[camera]
eye = [0, 1, 5]
target = [0, 0, 0]

[light]
position = [2, 4, 3]
intensity = 20

[textures.chk]
kind = "checker"
param = 8

[materials.red]
colour = [0.8, 0.1, 0.1]
reflection = "constant"
reflectivity = 0.5
texture = "chk"

[[objects]]
type = "sphere"
material = "red"
translate = [0, 1, 0]

[[objects]]
type = "plane"
"#;

#[test]
fn parses_a_small_scene() {
    let w = parse(Path::new("s.toml"), OK, &no_mesh).unwrap();
    assert_eq!(w.prims.len(), 2);
    assert_eq!(w.prims[0].kind, PrimKind::Sphere);
    assert_eq!(w.prims[1].kind, PrimKind::Square);
    assert_eq!(w.objects.len(), 2);
    assert_eq!(w.objects[1].kind, ObjectKind::Plane);
    assert_eq!(w.objects[1].first_prim, 1);
    assert_eq!(w.material_model[1].texture, TextureKind::Checker);
    assert_eq!(w.material_model[1].reflect_mode, ReflectMode::Constant);
    assert_eq!(w.mesh.materials[1].reflect, 0.5);
    assert_eq!(w.lighting.light_count, 1);
    assert_eq!(w.settings.light.intensity, 20.0);
    assert_eq!(w.settings.camera.eye, [0.0, 1.0, 5.0]);
}

#[test]
fn errors_name_line_and_field() {
    let e = err(&OK.replace("translate = [0, 1, 0]", "translate = [0, 1, 0]\nscale = 0"));
    assert!(e.contains("line 24") && e.contains("field `scale`") && e.contains("objects[0]"), "{e}");
    let e = err(&OK.replace("material = \"red\"", "material = \"blue\""));
    assert!(e.contains("field `material`") && e.contains("no material named `blue`"), "{e}");
    let e = err(&OK.replace("kind = \"checker\"", "kind = \"plaid\""));
    assert!(e.contains("line 11") && e.contains("plaid"), "{e}");
    let e = err(&OK.replace("intensity = 20", "intensity = 20\nbrightness = 3"));
    assert!(e.contains("line 9") && e.contains("brightness"), "{e}");
    let e = err(&OK.replace("texture = \"chk\"", "texture = \"nope\""));
    assert!(e.contains("materials.red") && e.contains("field `texture`"), "{e}");
    let e = err(&OK.replace("reflectivity = 0.5", "reflectivity = 1.5"));
    assert!(e.contains("line 17") && e.contains("field `reflectivity`"), "{e}");
    let e = err("[camera]\neye = [0, 0, 1]\ntarget = [0, 0, 1]\n[[objects]]\ntype = \"sphere\"\n");
    assert!(e.contains("field `target`"), "{e}");
}

#[test]
fn camera_path_keyframes_default_to_the_camera_and_are_checked() {
    let text = format!(
        "{OK}\n[[camera_path]]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\n\n[[camera_path]]\neye = [5, 1, 0]\ntarget = [0, 1, 0]\nfov = 30\n"
    );
    let w = parse(Path::new("s.toml"), &text, &no_mesh).unwrap();
    assert_eq!(w.camera_path.len(), 2);
    assert_eq!((w.camera_path[0].fov_y_deg, w.camera_path[0].up), (45.0, [0.0, 1.0, 0.0]));
    assert_eq!((w.camera_path[1].eye, w.camera_path[1].fov_y_deg), ([5.0, 1.0, 0.0], 30.0));
    assert!(parse(Path::new("s.toml"), OK, &no_mesh).unwrap().camera_path.is_empty());
    let e = err(&format!("{OK}\n[[camera_path]]\neye = [0, 0, 1]\ntarget = [0, 0, 1]\n"));
    assert!(e.contains("camera_path") && e.contains("field `target`"), "{e}");
    let e = err(&format!("{OK}\n[[camera_path]]\neye = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 200\n"));
    assert!(e.contains("field `fov`"), "{e}");
    let e = err(&format!("{OK}\n[[camera_path]]\neye = [0, 0, 1]\ntarget = [0, 0, 0]\nzoom = 2\n"));
    assert!(e.contains("zoom"), "{e}");
}
