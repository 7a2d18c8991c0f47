//! The scene classes of `benches/scene_classes.py` (open table, shelves
//! with dividers, a cage of thin bars, clutter), regenerated with Rust's RNG
//! (same shapes and ranges, different draws), for the Rust probes.

use ferrobot_collision::{CollisionWorld, Shape};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, rngs::StdRng};

/// A scene generator: adds a class's obstacles to the world.
pub type Gen = fn(&mut CollisionWorld, &mut StdRng);

/// The four classes, by name.
pub const CLASSES: [(&str, Gen); 4] = [
    ("table", table),
    ("shelves", shelves),
    ("cage", cage),
    ("clutter", clutter),
];

fn pose(x: f64, y: f64, z: f64, yaw: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
    )
}

fn add_box(w: &mut CollisionWorld, name: String, s: [f64; 3], p: Isometry3<f64>) {
    w.add_shape(&name, Shape::cuboid_from_size(Vector3::from(s)), p)
        .expect("box");
}

fn u(rng: &mut StdRng, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

/// An open table with four boxes on it.
pub fn table(w: &mut CollisionWorld, rng: &mut StdRng) {
    add_box(
        w,
        "table".into(),
        [0.8, 1.2, 0.04],
        pose(0.6, 0.0, 0.2, 0.0),
    );
    for i in 0..4 {
        let s = [0; 3].map(|_| u(rng, 0.04, 0.1));
        let p = pose(
            u(rng, 0.4, 0.8),
            u(rng, -0.4, 0.4),
            0.22 + s[2] / 2.0,
            u(rng, -3.0, 3.0),
        );
        add_box(w, format!("obj{i}"), s, p);
    }
}

/// A bookshelf with boards, a back and vertical dividers, six books.
pub fn shelves(w: &mut CollisionWorld, rng: &mut StdRng) {
    let x0 = u(rng, 0.55, 0.7);
    let (depth, width, th) = (0.35, 1.2, 0.02);
    let levels: Vec<f64> = (0..5).map(|k| 1.1 * k as f64 / 4.0).collect();
    for (k, z) in levels.iter().enumerate() {
        add_box(
            w,
            format!("board{k}"),
            [depth, width, th],
            pose(x0 + depth / 2.0, 0.0, *z, 0.0),
        );
    }
    add_box(
        w,
        "back".into(),
        [th, width, 1.1],
        pose(x0 + depth, 0.0, 0.55, 0.0),
    );
    for k in 0..4 {
        let (z, h) = (levels[k], levels[k + 1] - levels[k]);
        for j in 0..5 {
            let y = -width / 2.0 + width * j as f64 / 4.0;
            add_box(
                w,
                format!("divider{k}_{j}"),
                [depth, th, h],
                pose(x0 + depth / 2.0, y, z + h / 2.0, 0.0),
            );
        }
    }
    for i in 0..6 {
        let k = rng.random_range(0..4usize);
        let s = [0; 3].map(|_| u(rng, 0.03, 0.07));
        let p = pose(
            x0 + u(rng, 0.08, 0.25),
            u(rng, -0.5, 0.5),
            levels[k] + th / 2.0 + s[2] / 2.0,
            0.0,
        );
        add_box(w, format!("book{i}"), s, p);
    }
}

/// A cage of thin bars (vertical, rings, roof) around a table.
pub fn cage(w: &mut CollisionWorld, rng: &mut StdRng) {
    add_box(
        w,
        "table".into(),
        [0.7, 1.0, 0.04],
        pose(0.55, 0.0, 0.15, 0.0),
    );
    let r = u(rng, 0.75, 0.85);
    let bar = 0.015;
    let mut k = 0;
    let step = 2.0 * std::f64::consts::PI / 28.0;
    for i in 0..28 {
        let a = step * i as f64;
        let off = (a - std::f64::consts::PI)
            .sin()
            .atan2((a - std::f64::consts::PI).cos());
        if off.abs() < 0.5 {
            continue;
        }
        w.add_shape(
            &format!("bar{k}"),
            Shape::cylinder_from_length(bar, 1.3),
            pose(r * a.cos(), r * a.sin(), 0.45, 0.0),
        )
        .expect("bar");
        k += 1;
    }
    for z in [0.35, 0.7, 1.05] {
        for i in 0..28 {
            let a = step * i as f64;
            let size = [
                bar * 2.0,
                2.0 * r * (std::f64::consts::PI / 28.0).sin(),
                bar * 2.0,
            ];
            add_box(
                w,
                format!("ring{k}"),
                size,
                pose(r * a.cos(), r * a.sin(), z, a),
            );
            k += 1;
        }
    }
    for i in 0..12 {
        let x = -r + 2.0 * r * i as f64 / 11.0;
        add_box(
            w,
            format!("roof{k}"),
            [bar * 2.0, 2.0 * r, bar * 2.0],
            pose(x, 0.0, 1.1, 0.0),
        );
        k += 1;
    }
    for i in 0..8 {
        let s = [0; 3].map(|_| u(rng, 0.03, 0.08));
        let p = pose(u(rng, 0.35, 0.8), u(rng, -0.4, 0.4), 0.17 + s[2] / 2.0, 0.0);
        add_box(w, format!("obj{i}"), s, p);
    }
}

/// A table with 60-150 small boxes, cylinders and spheres, a third floating.
pub fn clutter(w: &mut CollisionWorld, rng: &mut StdRng) {
    add_box(
        w,
        "table".into(),
        [0.9, 1.4, 0.04],
        pose(0.6, 0.0, 0.1, 0.0),
    );
    let n = rng.random_range(60..150usize);
    for i in 0..n {
        let (x, y) = (u(rng, 0.3, 0.95), u(rng, -0.65, 0.65));
        let z = 0.12 + if i % 3 == 0 { u(rng, 0.0, 0.6) } else { 0.0 };
        let name = format!("c{i}");
        match i % 3 {
            0 => {
                let s = [0; 3].map(|_| u(rng, 0.02, 0.06));
                add_box(w, name, s, pose(x, y, z + s[2] / 2.0, u(rng, -3.0, 3.0)));
            }
            1 => {
                let (rad, len) = (u(rng, 0.01, 0.03), u(rng, 0.03, 0.12));
                w.add_shape(
                    &name,
                    Shape::cylinder_from_length(rad, len),
                    pose(x, y, z + len / 2.0, 0.0),
                )
                .expect("cylinder");
            }
            _ => {
                let rad = u(rng, 0.01, 0.03);
                w.add_shape(
                    &name,
                    Shape::Sphere { radius: rad },
                    pose(x, y, z + rad, 0.0),
                )
                .expect("sphere");
            }
        }
    }
}
