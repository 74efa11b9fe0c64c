//! A workspace of tool-point positions for any mechanism whose targets are
//! points: a vertical cylinder below the base, the layered pose pattern in
//! it, the workspace grid accuracy is judged over (docs/method.md §7, §12)
//! and the ISO 9283 test positions. Pure geometry: no mechanism's model.

use nalgebra::Vector3;

/// A cylindrical workspace of tool-point positions: x² + y² ≤ radius²,
/// top ≤ z ≤ top + height (the paper's Table 1 is the Tricept's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    pub radius_mm: f64,
    pub height_mm: f64,
    pub top_mm: f64,
}

impl Workspace {
    /// z of the mid-plane, H + h/2.
    pub fn mid_z(&self) -> f64 {
        self.top_mm + self.height_mm / 2.0
    }

    /// z of layer k of `layers` planes spaced evenly from the top face to the
    /// bottom face (one layer: the mid-plane).
    pub fn layer_z(&self, k: usize, layers: usize) -> f64 {
        if layers <= 1 {
            self.mid_z()
        } else {
            self.top_mm + self.height_mm * k as f64 / (layers - 1) as f64
        }
    }

    /// Is the point inside the cylinder (with a small tolerance)?
    pub fn contains(&self, r: &Vector3<f64>) -> bool {
        let tol = 1e-9 * (1.0 + self.radius_mm + self.top_mm + self.height_mm);
        r.x.hypot(r.y) <= self.radius_mm + tol
            && r.z >= self.top_mm - tol
            && r.z <= self.top_mm + self.height_mm + tol
    }
}

/// The layered pattern: `layers` planes evenly from the top face to the
/// bottom face (one layer: the mid-plane); on each the centre, then for each
/// ring fraction f a ring of `points_per_ring` points of radius f·R at angles
/// 0, 360/k, … degrees. The first pose is the reference.
pub fn pattern(
    ws: &Workspace,
    layers: usize,
    ring_fractions: &[f64],
    points_per_ring: usize,
) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(layers * (1 + ring_fractions.len() * points_per_ring));
    for k in 0..layers {
        let z = ws.layer_z(k, layers);
        out.push(Vector3::new(0.0, 0.0, z));
        for f in ring_fractions {
            for p in 0..points_per_ring {
                let t = (360.0 * p as f64 / points_per_ring as f64).to_radians();
                let rad = f * ws.radius_mm;
                out.push(Vector3::new(rad * t.cos(), rad * t.sin(), z));
            }
        }
    }
    out
}

/// Grid points (i·s, j·s, z) with (i·s)² + (j·s)² ≤ R², row-major in y then x.
pub fn midplane_grid(ws: &Workspace, step_mm: f64, z: f64) -> Vec<Vector3<f64>> {
    let n = (ws.radius_mm / step_mm).floor() as i64;
    let r2 = ws.radius_mm * ws.radius_mm * (1.0 + 1e-12);
    let mut out = Vec::new();
    for j in -n..=n {
        for i in -n..=n {
            let (x, y) = (i as f64 * step_mm, j as f64 * step_mm);
            if x * x + y * y <= r2 {
                out.push(Vector3::new(x, y, z));
            }
        }
    }
    out
}

/// The workspace grid of docs/method.md §12: the plane grid of step `step_mm` on each
/// of `layers` planes from the top face to the bottom face (one layer: the
/// mid-plane), layer by layer.
pub fn workspace_grid(ws: &Workspace, step_mm: f64, layers: usize) -> Vec<Vector3<f64>> {
    (0..layers)
        .flat_map(|k| midplane_grid(ws, step_mm, ws.layer_z(k, layers)))
        .collect()
}

/// ISO 9283 test positions P1–P5 in the largest cube inscribed in the
/// workspace cylinder (side a = min(R·√2, h), centred on the mid-plane, faces
/// parallel to the axes), on the cube's diagonal plane through the x = y
/// diagonal: P1 the centre, P2–P5 on the plane's diagonals at 10 % of their
/// length from the cube's edges (0.8 of the way from the centre to a
/// corner): P2 (+x, +y, top face side), P3 (+x, +y, bottom), P4 (−x, −y,
/// bottom), P5 (−x, −y, top).
pub fn iso9283_positions(ws: &Workspace) -> [Vector3<f64>; 5] {
    let a = (ws.radius_mm * std::f64::consts::SQRT_2).min(ws.height_mm);
    let c = Vector3::new(0.0, 0.0, ws.mid_z());
    let d = 0.8 * a / 2.0;
    let at = |s: f64, sz: f64| c + Vector3::new(s * d, s * d, sz * d);
    [
        c,
        at(1.0, -1.0),
        at(1.0, 1.0),
        at(-1.0, 1.0),
        at(-1.0, -1.0),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's Table 1 cylinder.
    const TABLE_1: Workspace = Workspace {
        radius_mm: 400.0,
        height_mm: 200.0,
        top_mm: 650.0,
    };

    #[test]
    fn default_pattern_has_51_poses_reference_first() {
        let p = pattern(&TABLE_1, 3, &[0.5, 1.0], 8);
        assert_eq!(p.len(), 51);
        assert_eq!(p[0], Vector3::new(0.0, 0.0, 650.0));
        assert_eq!(p[17], Vector3::new(0.0, 0.0, 750.0));
        assert!((p[9].x - 400.0).abs() < 1e-12);
    }

    #[test]
    fn workspace_grid_stacks_the_layers() {
        let ws = TABLE_1;
        let g = workspace_grid(&ws, 20.0, 5);
        assert_eq!(g.len(), 5 * 1257);
        assert_eq!(g[0].z, 650.0);
        assert_eq!(g[4 * 1257].z, 850.0);
        assert_eq!(g[2 * 1257].z, 750.0);
        assert_eq!(
            workspace_grid(&ws, 20.0, 1),
            midplane_grid(&ws, 20.0, 750.0)
        );
    }

    #[test]
    fn iso9283_positions_lie_in_the_inscribed_cube() {
        let ws = TABLE_1;
        let p = iso9283_positions(&ws);
        // R = 400, h = 200: the cube's side is the height, 200 mm.
        assert_eq!(p[0], Vector3::new(0.0, 0.0, 750.0));
        assert!((p[1] - Vector3::new(80.0, 80.0, 670.0)).norm() < 1e-12);
        assert!((p[3] - Vector3::new(-80.0, -80.0, 830.0)).norm() < 1e-12);
        for q in &p {
            assert!(ws.contains(q));
            assert!((q.x - q.y).abs() < 1e-12, "on the diagonal plane");
        }
        // 10 % of the diagonal from the corners: |P2 − P1| = 0.8 × half-diagonal.
        let half_diag = (3.0f64).sqrt() * 100.0;
        assert!(((p[1] - p[0]).norm() - 0.8 * half_diag).abs() < 1e-9);
    }

    #[test]
    fn midplane_grid_has_1257_points() {
        let ws = TABLE_1;
        let g = midplane_grid(&ws, 20.0, ws.mid_z());
        assert_eq!(g.len(), 1257);
    }
}
