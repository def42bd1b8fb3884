//! Camera paths of a frame stream (`gridrt render --frames N`): an orbit around the scene's
//! centre (`--orbit DEGREES`) or the keyframes of a scene file (`[[camera_path]]`,
//! docs/SCENE-FILE.md), interpolated linearly.
//!
//! Frame `i` of `n` on an orbit is the base camera turned by `i × degrees / n` about the
//! vertical axis (the camera's `up`) through the centre: eye and target turn, `up` and the
//! field of view stay. On keyframes, frame `i` sits at `u = i / (n − 1)` of the path (the
//! first frame on the first keyframe, the last on the last; keyframes evenly spaced) and
//! every field (eye, target, up, fov) is interpolated linearly between its two keyframes.

use crate::render_settings::Camera;

/// How the camera moves from frame to frame.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraPath {
    /// The same camera on every frame.
    Still,
    /// Turn about the vertical axis through `centre`, `degrees` over the whole stream.
    Orbit {
        /// Degrees over the `n` frames (frame `i` at `i × degrees / n`).
        degrees: f64,
        /// Centre of rotation (the scene's centre).
        centre: [f64; 3],
    },
    /// Keyframes, evenly spaced over the stream, interpolated linearly (at least one).
    Keyframes(Vec<Camera>),
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn wide(v: [f32; 3]) -> [f64; 3] {
    v.map(f64::from)
}

/// `p` turned by `angle` radians about the unit axis `k` through `c` (Rodrigues).
fn turn(p: [f64; 3], c: [f64; 3], k: [f64; 3], angle: f64) -> [f64; 3] {
    let v = sub(p, c);
    let (s, co) = angle.sin_cos();
    let cross = [k[1] * v[2] - k[2] * v[1], k[2] * v[0] - k[0] * v[2], k[0] * v[1] - k[1] * v[0]];
    let dot = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    [0, 1, 2].map(|i| c[i] + v[i] * co + cross[i] * s + k[i] * dot * (1.0 - co))
}

fn lerp3(a: [f32; 3], b: [f32; 3], t: f64) -> [f32; 3] {
    [0, 1, 2].map(|i| (f64::from(a[i]) + (f64::from(b[i]) - f64::from(a[i])) * t) as f32)
}

impl CameraPath {
    /// The camera of frame `i` of `n` (`base`: the scene's camera, used by `Still` and
    /// `Orbit`).
    pub fn camera(&self, base: &Camera, i: u32, n: u32) -> Camera {
        match self {
            Self::Still => *base,
            Self::Orbit { degrees, centre } => {
                let angle = (f64::from(i) * degrees / f64::from(n.max(1))).to_radians();
                let up = wide(base.up);
                let len = (up[0] * up[0] + up[1] * up[1] + up[2] * up[2]).sqrt();
                let k = if len > 0.0 { up.map(|c| c / len) } else { [0.0, 1.0, 0.0] };
                Camera {
                    eye: turn(wide(base.eye), *centre, k, angle).map(|c| c as f32),
                    target: turn(wide(base.target), *centre, k, angle).map(|c| c as f32),
                    ..*base
                }
            }
            Self::Keyframes(keys) => {
                let Some(first) = keys.first() else { return *base };
                if keys.len() == 1 || n <= 1 {
                    return *first;
                }
                let u = f64::from(i.min(n - 1)) / f64::from(n - 1) * (keys.len() - 1) as f64;
                let k = (u.floor() as usize).min(keys.len() - 2);
                let t = u - k as f64;
                let (a, b) = (&keys[k], &keys[k + 1]);
                Camera {
                    eye: lerp3(a.eye, b.eye, t),
                    target: lerp3(a.target, b.target, t),
                    up: lerp3(a.up, b.up, t),
                    fov_y_deg: (f64::from(a.fov_y_deg) + (f64::from(b.fov_y_deg) - f64::from(a.fov_y_deg)) * t) as f32,
                }
            }
        }
    }

    /// Checks every frame's camera of an `n`-frame stream: finite, eye ≠ target, `up` not
    /// parallel to the view, fov in (0, 180). The first bad frame, in words.
    pub fn check(&self, base: &Camera, n: u32) -> Result<(), String> {
        for i in 0..n {
            let c = self.camera(base, i, n);
            let f = sub(wide(c.target), wide(c.eye));
            let u = wide(c.up);
            let cross = [f[1] * u[2] - f[2] * u[1], f[2] * u[0] - f[0] * u[2], f[0] * u[1] - f[1] * u[0]];
            let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let finite = [c.eye, c.target, c.up].iter().flatten().all(|v| v.is_finite());
            if !finite || norm(f) == 0.0 || norm(cross) <= 1e-9 * norm(f) * norm(u) {
                return Err(format!("frame {i}: the camera is degenerate (eye = target, or up along the view)"));
            }
            if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
                return Err(format!("frame {i}: fov {} is outside (0, 180) degrees", c.fov_y_deg));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(eye: [f32; 3]) -> Camera {
        Camera { eye, target: [0.0; 3], up: [0.0, 1.0, 0.0], fov_y_deg: 45.0 }
    }

    #[test]
    fn an_orbit_turns_the_eye_about_the_vertical_through_the_centre() {
        let p = CameraPath::Orbit { degrees: 360.0, centre: [0.0; 3] };
        let base = cam([0.0, 1.0, 5.0]);
        assert_eq!(p.camera(&base, 0, 4), base);
        let q = p.camera(&base, 1, 4); // 90°: +z turns to +x about +y
        assert!((q.eye[0] - 5.0).abs() < 1e-5 && q.eye[2].abs() < 1e-5 && q.eye[1] == 1.0, "{q:?}");
        let h = p.camera(&base, 2, 4);
        assert!((h.eye[2] + 5.0).abs() < 1e-5 && h.eye[0].abs() < 1e-5, "{h:?}");
        // Off-centre: the target turns too, distances to the centre stay.
        let p = CameraPath::Orbit { degrees: 90.0, centre: [1.0, 0.0, 0.0] };
        let b = Camera { target: [1.0, 0.0, 0.0], ..cam([1.0, 0.0, 3.0]) };
        let c = p.camera(&b, 1, 1);
        assert!((c.eye[0] - 4.0).abs() < 1e-5 && c.eye[2].abs() < 1e-5 && c.target == b.target, "{c:?}");
        assert!(p.check(&b, 8).is_ok());
    }

    #[test]
    fn keyframes_are_interpolated_linearly_from_first_to_last() {
        let a = cam([0.0, 0.0, 4.0]);
        let b = Camera { fov_y_deg: 65.0, ..cam([4.0, 0.0, 4.0]) };
        let c = cam([4.0, 4.0, 4.0]);
        let p = CameraPath::Keyframes(vec![a, b, c]);
        assert_eq!(p.camera(&a, 0, 5), a);
        assert_eq!(p.camera(&a, 4, 5), c);
        assert_eq!(p.camera(&a, 2, 5), b);
        let q = p.camera(&a, 1, 5);
        assert_eq!((q.eye, q.fov_y_deg), ([2.0, 0.0, 4.0], 55.0));
        let r = p.camera(&a, 3, 5);
        assert_eq!((r.eye, r.fov_y_deg), ([4.0, 2.0, 4.0], 55.0));
        assert_eq!(p.camera(&a, 0, 1), a);
        // A path through the target is refused frame by frame.
        let bad = CameraPath::Keyframes(vec![cam([0.0, 0.0, -1.0]), cam([0.0, 0.0, 1.0])]);
        assert!(bad.check(&a, 3).unwrap_err().starts_with("frame 1"));
    }
}
