//! A point cloud as a scene: its points as oriented disks (ViRAY's disk primitive) for the
//! ray tracer and the f64 reference, and the same points in the scene image's point section
//! (SPEC.md §5.10) for the splat path.

use gridrt_shared::frame::crc32;
use gridrt_shared::scene::{scene_flags, PointRecord, PointsHead, PrimKind, SceneHeader, HEADER_LEN};

use super::cloud::PointCloud;
use crate::grid::{build_with_prims, GridError, GridParams};
use crate::render_settings::RenderSettings;
use crate::scene::{AnalyticPrim, Bounds, LoadStats, Mesh, Scene};
use crate::scene_image::PreparedScene;

/// The disk of a point: the canonical disk (y = 0, x² + z² ≤ 1) scaled by the radius, its y
/// axis along the normal, centred on the point.
pub fn disk(p: &super::cloud::CloudPoint) -> Option<AnalyticPrim> {
    let n = p.normal.map(f64::from);
    // Any unit tangent: cross with the axis least aligned with n.
    let a = if n[0].abs() < 0.6 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
    let t1 = normalize([n[1] * a[2] - n[2] * a[1], n[2] * a[0] - n[0] * a[2], n[0] * a[1] - n[1] * a[0]])?;
    let t2 = [n[1] * t1[2] - n[2] * t1[1], n[2] * t1[0] - n[0] * t1[2], n[0] * t1[1] - n[1] * t1[0]];
    let r = p.radius as f64;
    let m = [0, 1, 2].map(|i| [t1[i] * r, n[i] * r, t2[i] * r, p.pos[i] as f64]);
    AnalyticPrim::new(PrimKind::Disk, p.material as u32, m)
}

fn normalize(v: [f64; 3]) -> Option<[f64; 3]> {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (l > 0.0).then(|| v.map(|c| c / l))
}

/// The scene of a cloud: no triangles, one disk per point, the cloud's palette as matte
/// materials, mesh lighting, and the default camera of the cloud's box.
pub fn cloud_scene(cloud: &PointCloud) -> Scene {
    let mesh = Mesh { triangles: Vec::new(), materials: cloud.materials.clone(), stats: LoadStats::default() };
    let mut scene = Scene::from_mesh(mesh);
    scene.prims = cloud.points.iter().filter_map(disk).collect();
    scene.settings = RenderSettings::default_for(&cloud.bounds());
    scene
}

/// The point section of `cloud`; `bounds` is the box of the whole cloud it belongs to (a
/// sort-last subset gets its parent's, so every board quantises depth alike).
pub fn point_section(cloud: &PointCloud, bounds: &Bounds) -> Vec<u8> {
    let head = PointsHead { count: cloud.points.len() as u32, bounds_min: bounds.min, bounds_max: bounds.max };
    let mut out = head.to_bytes().to_vec();
    for p in &cloud.points {
        let r = PointRecord { pos: p.pos, normal: p.normal, radius: p.radius, material: p.material };
        out.extend_from_slice(&r.to_bytes());
    }
    out
}

/// Appends a point section to a scene image: sets `POINTS`, fixes `total_len` and the body
/// CRC.
pub fn with_points(image: &[u8], section: &[u8]) -> Option<Vec<u8>> {
    let mut h = SceneHeader::parse(image).ok()?;
    let mut body = image.get(HEADER_LEN..)?.to_vec();
    body.extend_from_slice(section);
    h.flags |= scene_flags::POINTS;
    h.total_len = u32::try_from(HEADER_LEN + body.len()).ok()?;
    h.body_crc = crc32(&body);
    let mut out = h.to_bytes().to_vec();
    out.extend_from_slice(&body);
    Some(out)
}

/// Builds the grid of the disks and the scene image with the point section.
pub fn prepare(cloud: &PointCloud, whole: &Bounds, params: &GridParams) -> Result<PreparedScene, GridError> {
    let scene = cloud_scene(cloud);
    let grid = build_with_prims(&scene.mesh, &scene.prims, params)?;
    let image = crate::image_format::scene_image(&grid, &scene);
    let image = with_points(&image, &point_section(cloud, whole)).unwrap_or(image);
    Ok(PreparedScene { scene, grid, image })
}
