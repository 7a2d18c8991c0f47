//! A closed convex mesh is its own convex decomposition (one part, its hull,
//! the same volume as the hand formula); a concave mesh still goes through
//! V-HACD and keeps its dent (the decomposition's volume stays below the
//! hull's).

use ferrobot_geometry::Mesh;
use nalgebra::Point3;

/// A closed, outward-wound box mesh with half extents `h` centred at `c`.
fn boxed(h: [f64; 3], c: [f64; 3]) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for x in [-1.0, 1.0] {
        for y in [-1.0, 1.0] {
            for z in [-1.0, 1.0] {
                v.push(Point3::new(
                    c[0] + x * h[0],
                    c[1] + y * h[1],
                    c[2] + z * h[2],
                ));
            }
        }
    }
    let f = vec![
        [0, 1, 3],
        [0, 3, 2],
        [4, 6, 7],
        [4, 7, 5],
        [0, 4, 5],
        [0, 5, 1],
        [2, 3, 7],
        [2, 7, 6],
        [0, 2, 6],
        [0, 6, 4],
        [1, 5, 7],
        [1, 7, 3],
    ];
    (v, f)
}

/// A UV sphere of radius `r`: `rings` latitude rings, `seg` segments; closed
/// and convex (every vertex on the sphere, planar triangles).
fn sphere(r: f64, rings: u32, seg: u32) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let mut v = vec![Point3::new(0.0, 0.0, -r)];
    for i in 1..rings {
        let p = std::f64::consts::PI * f64::from(i) / f64::from(rings);
        for j in 0..seg {
            let a = 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(seg);
            v.push(Point3::new(
                r * p.sin() * a.cos(),
                r * p.sin() * a.sin(),
                -r * p.cos(),
            ));
        }
    }
    v.push(Point3::new(0.0, 0.0, r));
    let top = v.len() as u32 - 1;
    let mut f = Vec::new();
    for j in 0..seg {
        let k = (j + 1) % seg;
        f.push([0, 1 + k, 1 + j]);
        for i in 0..rings - 2 {
            let (lo, hi) = (1 + i * seg, 1 + (i + 1) * seg);
            f.push([lo + j, lo + k, hi + k]);
            f.push([lo + j, hi + k, hi + j]);
        }
        let last = 1 + (rings - 2) * seg;
        f.push([top, last + j, last + k]);
    }
    (v, f)
}

fn parts_and_volume(v: Vec<Point3<f64>>, f: Vec<[u32; 3]>) -> (usize, f64) {
    let mesh = Mesh::new(v, f).unwrap();
    let shape = mesh.convex_decomposition().unwrap();
    let compound = shape.as_compound().expect("a compound");
    let volume: f64 = compound
        .shapes()
        .iter()
        .map(|(_, s)| f64::from(s.mass_properties(1.0).mass()))
        .sum();
    (compound.shapes().len(), volume)
}

#[test]
fn a_box_is_one_part_of_its_own_volume() {
    let (v, f) = boxed([0.025, 0.016, 0.0115], [0.01, -0.02, 0.03]);
    let (n, vol) = parts_and_volume(v, f);
    let exact = 8.0 * 0.025 * 0.016 * 0.0115;
    assert_eq!(n, 1);
    assert!((vol - exact).abs() < 1e-5 * exact, "{vol} vs {exact}");
}

#[test]
fn a_tessellated_sphere_is_one_part() {
    let (v, f) = sphere(0.03, 24, 48);
    let (n, vol) = parts_and_volume(v, f);
    let ball = 4.0 / 3.0 * std::f64::consts::PI * 0.03f64.powi(3);
    assert_eq!(n, 1);
    // An inscribed polyhedron: a little less than the ball, by well under 1 %.
    assert!(vol < ball && vol > 0.99 * ball, "{vol} vs {ball}");
}

#[test]
fn a_concave_mesh_is_still_decomposed() {
    // Two boxes side by side with a gap, as one mesh: the hull bridges the
    // gap (volume 0.06^2 x 0.16 = 5.76e-4), the solid holds 2 x 0.06^3 =
    // 4.32e-4; the decomposition must not take the hull.
    let (mut v, mut f) = boxed([0.03, 0.03, 0.03], [-0.05, 0.0, 0.0]);
    let (v2, f2) = boxed([0.03, 0.03, 0.03], [0.05, 0.0, 0.0]);
    let n0 = v.len() as u32;
    v.extend(v2);
    f.extend(f2.into_iter().map(|t| [t[0] + n0, t[1] + n0, t[2] + n0]));
    let (n, vol) = parts_and_volume(v, f);
    assert!(n >= 2, "{n} parts");
    assert!(vol < 0.5 * (4.32e-4 + 5.76e-4), "{vol}");
}
